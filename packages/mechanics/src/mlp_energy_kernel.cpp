#include "mlp_energy_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel_for.hpp"

namespace demnerf::mechanics::mlp_kernel {
namespace {

// 16 points in the lanes of one vector (one AVX-512 register, or two AVX2 ones); a chunk is kV of
// them. Per hidden unit the forward pass carries four channels: the value and its three
// X-derivatives.
typedef float v16 __attribute__((vector_size(64)));
typedef int vi16 __attribute__((vector_size(64)));
constexpr int kLanes = 16, kV = 2, kChunk = kLanes * kV;

inline v16 splat(float s) { return v16{} + s; }

inline float laneSum(v16 v) {
  float s = 0.0f;
  for (int i = 0; i < kLanes; ++i) s += v[i];
  return s;
}

// e^x for |x| <= 18 (tanh's range): x = n ln2 + r, |r| <= ln2 / 2, e^r by its Taylor series to
// r^7 (relative error 5e-9), 2^n put into the exponent bits.
inline v16 vexp(v16 x) {
  const v16 t = x * 1.44269504f;
  const vi16 n = __builtin_convertvector(t + 128.5f, vi16) - 128;  // floor(t + 0.5): t + 128.5 > 0
  const v16 nf = __builtin_convertvector(n, v16);
  const v16 r = (x - nf * 0.693145752f) - nf * 1.42860677e-6f;
  v16 p = splat(1.0f / 5040);
  p = p * r + 1.0f / 720;
  p = p * r + 1.0f / 120;
  p = p * r + 1.0f / 24;
  p = p * r + 1.0f / 6;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  const vi16 bits = (n + 127) << 23;
  return p * reinterpret_cast<const v16&>(bits);
}

inline v16 vtanh(v16 a) {
  const v16 lo = splat(-9.0f), hi = splat(9.0f);
  a = a < lo ? lo : a;
  a = a > hi ? hi : a;
  const v16 e = vexp(a + a);
  return (e - 1.0f) / (e + 1.0f);
}

// One thread's buffers: the forward pass's layers for a chunk, the backward pass's adjoints and
// the parameter gradient's accumulators (16 lanes each, summed at the end).
struct Workspace {
  struct Layer {
    std::vector<v16> h, s1, da, dh;  // [unit][v], [unit][v], [unit][k][v], [unit][k][v]
  };
  std::vector<Layer> layers;
  std::vector<v16> xin, z, dz, gz, gdz, gh, gdh, ga, gda, next_gh, next_gdh;
  std::vector<std::vector<v16>> gw, gb;
  double energy = 0.0, penalty = 0.0, min_J = std::numeric_limits<double>::infinity();
  bool admissible = true;

  explicit Workspace(const Network& net) : layers(net.depth) {
    const std::size_t w = net.width;
    for (Layer& l : layers) {
      l.h.resize(w * kV);
      l.s1.resize(w * kV);
      l.da.resize(3 * w * kV);
      l.dh.resize(3 * w * kV);
    }
    xin.resize(3 * kV);
    z.resize(3 * kV);
    dz.resize(9 * kV);
    gz.resize(3 * kV);
    gdz.resize(9 * kV);
    for (auto* b : {&gh, &ga, &next_gh}) b->resize(w * kV);
    for (auto* b : {&gdh, &gda, &next_gdh}) b->resize(3 * w * kV);
    for (int l = 0; l <= net.depth; ++l) {
      const std::size_t in = l == 0 ? 3 : w, out = l == net.depth ? 3 : w;
      gw.emplace_back(in * out, v16{});
      gb.emplace_back(out, v16{});
    }
  }
};

// Forward pass of the chunk starting at point p0 (m <= kChunk points; the rest of the lanes 0).
// Deriv: also the X-derivatives.
template <bool Deriv>
void forwardChunk(const Network& net, const float* x, std::int64_t p0, int m, Workspace& ws) {
  for (int i = 0; i < 3; ++i)
    for (int v = 0; v < kV; ++v)
      for (int l = 0; l < kLanes; ++l) {
        const int q = v * kLanes + l;
        ws.xin[i * kV + v][l] = q < m ? (x[3 * (p0 + q) + i] - net.center[i]) * net.inv_half[i] : 0.0f;
      }
  const int w = net.width;
  for (int layer = 0; layer < net.depth; ++layer) {
    Workspace::Layer& L = ws.layers[layer];
    const float* W = net.weights[layer];
    const int in = layer == 0 ? 3 : w;
    const std::vector<v16>& hin = layer == 0 ? ws.xin : ws.layers[layer - 1].h;
    for (int j = 0; j < w; ++j) {
      v16 a[kV], da[3][kV];
      for (int v = 0; v < kV; ++v) {
        a[v] = splat(net.biases[layer][j]);
        for (int k = 0; k < 3; ++k) da[k][v] = layer == 0 ? splat(W[j * 3 + k] * net.inv_half[k]) : v16{};
      }
      for (int i = 0; i < in; ++i) {
        const float c = W[j * in + i];
        for (int v = 0; v < kV; ++v) a[v] += c * hin[i * kV + v];
        if (Deriv && layer > 0)
          for (int k = 0; k < 3; ++k)
            for (int v = 0; v < kV; ++v) da[k][v] += c * ws.layers[layer - 1].dh[(i * 3 + k) * kV + v];
      }
      for (int v = 0; v < kV; ++v) {
        const v16 h = vtanh(a[v]), s1 = 1.0f - h * h;
        L.h[j * kV + v] = h;
        L.s1[j * kV + v] = s1;
        if (Deriv)
          for (int k = 0; k < 3; ++k) {
            L.da[(j * 3 + k) * kV + v] = da[k][v];
            L.dh[(j * 3 + k) * kV + v] = s1 * da[k][v];
          }
      }
    }
  }
  const Workspace::Layer& last = ws.layers[net.depth - 1];
  const float* W = net.weights[net.depth];
  for (int o = 0; o < 3; ++o)
    for (int v = 0; v < kV; ++v) {
      v16 z = splat(net.biases[net.depth][o]), dz[3] = {v16{}, v16{}, v16{}};
      for (int i = 0; i < w; ++i) {
        const float c = W[o * w + i];
        z += c * last.h[i * kV + v];
        if (Deriv)
          for (int k = 0; k < 3; ++k) dz[k] += c * last.dh[(i * 3 + k) * kV + v];
      }
      ws.z[o * kV + v] = z;
      if (Deriv)
        for (int k = 0; k < 3; ++k) ws.dz[(o * 3 + k) * kV + v] = dz[k];
    }
}

// The output layer's share of the backward pass: its gradient, and the adjoints gh, gdh of the
// last hidden layer from those of z and dz.
template <bool Deriv>
void backwardOutput(const Network& net, Workspace& ws) {
  const int w = net.width;
  const Workspace::Layer& last = ws.layers[net.depth - 1];
  const float* W = net.weights[net.depth];
  std::vector<v16>& gW = ws.gw[net.depth];
  for (int o = 0; o < 3; ++o)
    for (int v = 0; v < kV; ++v) ws.gb[net.depth][o] += ws.gz[o * kV + v];
  for (int o = 0; o < 3; ++o)
    for (int i = 0; i < w; ++i) {
      v16 acc = gW[o * w + i];
      for (int v = 0; v < kV; ++v) {
        acc += ws.gz[o * kV + v] * last.h[i * kV + v];
        if (Deriv)
          for (int k = 0; k < 3; ++k) acc += ws.gdz[(o * 3 + k) * kV + v] * last.dh[(i * 3 + k) * kV + v];
      }
      gW[o * w + i] = acc;
    }
  for (int i = 0; i < w; ++i)
    for (int v = 0; v < kV; ++v) {
      v16 g{}, gd[3] = {v16{}, v16{}, v16{}};
      for (int o = 0; o < 3; ++o) {
        const float c = W[o * w + i];
        g += c * ws.gz[o * kV + v];
        if (Deriv)
          for (int k = 0; k < 3; ++k) gd[k] += c * ws.gdz[(o * 3 + k) * kV + v];
      }
      ws.gh[i * kV + v] = g;
      if (Deriv)
        for (int k = 0; k < 3; ++k) ws.gdh[(i * 3 + k) * kV + v] = gd[k];
    }
}

// Backward pass of the chunk from the adjoints gz, gdz of z and dz, into the accumulators.
template <bool Deriv>
void backwardChunk(const Network& net, Workspace& ws) {
  const int w = net.width;
  backwardOutput<Deriv>(net, ws);
  for (int layer = net.depth - 1; layer >= 0; --layer) {
    const Workspace::Layer& L = ws.layers[layer];
    // Through tanh: h = tanh(a), dh_k = s1 da_k with s1 = 1 - h^2 and ds1/da = -2 h s1.
    for (int j = 0; j < w; ++j)
      for (int v = 0; v < kV; ++v) {
        const int q = j * kV + v;
        v16 ga = ws.gh[q] * L.s1[q];
        if (Deriv) {
          v16 gs1{};
          for (int k = 0; k < 3; ++k) {
            const int r = (j * 3 + k) * kV + v;
            gs1 += ws.gdh[r] * L.da[r];
            ws.gda[r] = L.s1[q] * ws.gdh[r];
          }
          ga += gs1 * (-2.0f * L.h[q] * L.s1[q]);
        }
        ws.ga[q] = ga;
        ws.gb[layer][j] += ga;
      }
    std::vector<v16>& gW = ws.gw[layer];
    if (layer == 0) {
      for (int j = 0; j < w; ++j)
        for (int v = 0; v < kV; ++v)
          for (int i = 0; i < 3; ++i) {
            gW[j * 3 + i] += ws.ga[j * kV + v] * ws.xin[i * kV + v];
            if (Deriv) gW[j * 3 + i] += net.inv_half[i] * ws.gda[(j * 3 + i) * kV + v];
          }
      break;
    }
    const Workspace::Layer& P = ws.layers[layer - 1];
    const float* W = net.weights[layer];
    for (int j = 0; j < w; ++j)
      for (int i = 0; i < w; ++i) {
        v16 acc = gW[j * w + i];
        for (int v = 0; v < kV; ++v) {
          acc += ws.ga[j * kV + v] * P.h[i * kV + v];
          if (Deriv)
            for (int k = 0; k < 3; ++k) acc += ws.gda[(j * 3 + k) * kV + v] * P.dh[(i * 3 + k) * kV + v];
        }
        gW[j * w + i] = acc;
      }
    for (int i = 0; i < w; ++i) {
      v16 g[kV], gd[3][kV];
      for (int v = 0; v < kV; ++v) {
        g[v] = v16{};
        for (int k = 0; k < 3; ++k) gd[k][v] = v16{};
      }
      for (int j = 0; j < w; ++j) {
        const float c = W[j * w + i];
        for (int v = 0; v < kV; ++v) g[v] += c * ws.ga[j * kV + v];
        if (Deriv)
          for (int k = 0; k < 3; ++k)
            for (int v = 0; v < kV; ++v) gd[k][v] += c * ws.gda[(j * 3 + k) * kV + v];
      }
      for (int v = 0; v < kV; ++v) {
        ws.next_gh[i * kV + v] = g[v];
        if (Deriv)
          for (int k = 0; k < 3; ++k) ws.next_gdh[(i * 3 + k) * kV + v] = gd[k][v];
      }
    }
    std::swap(ws.gh, ws.next_gh);
    std::swap(ws.gdh, ws.next_gdh);
  }
}

inline float& lane(std::vector<v16>& a, int row, int q) { return a[row * kV + q / kLanes][q % kLanes]; }

// The energy density from J and I1 = tr(F^T F), and its stress P = a F + f cof(F): both models'
// dPsi/dF have that form, since dJ/dF = cof F and dI1/dF = 2 F.
struct Density {
  double value, a, f;
};

Density density(const Problem& pb, double J, double I1) {
  const double lnJ = std::log(J);
  if (pb.decoupled) {
    const double Jm = std::pow(J, -2.0 / 3.0);
    return {0.25 * pb.kappa * (J * J - 1 - 2 * lnJ) + 0.5 * pb.mu * (Jm * I1 - 3), pb.mu * Jm,
            0.5 * pb.kappa * (J - 1 / J) - pb.mu * Jm * I1 / (3 * J)};
  }
  return {0.5 * pb.mu * (I1 - 3) - pb.mu * lnJ + 0.5 * pb.lambda * lnJ * lnJ, pb.mu, (pb.lambda * lnJ - pb.mu) / J};
}

// The mechanics at one volume point in double: energy density, det F, and the adjoints of z and
// its X-derivatives (already / energy_scale). False when det F <= 0 or not finite.
bool volumePoint(const Problem& pb, std::int64_t p, Workspace& ws, int q) {
  const VolumePoints& vp = pb.volume;
  const double A = pb.output_scale, s = pb.load_scale, wq = vp.weight[p];
  double z[3], H[3][3], u[3], D[3];
  for (int i = 0; i < 3; ++i) {
    z[i] = lane(ws.z, i, q);
    D[i] = vp.D ? vp.D[3 * p + i] : 1.0;
    u[i] = (vp.g ? s * vp.g[3 * p + i] : 0.0) + D[i] * A * z[i];
    for (int k = 0; k < 3; ++k)
      H[i][k] = (vp.g ? s * vp.grad_g[9 * p + 3 * i + k] + vp.grad_D[9 * p + 3 * i + k] * A * z[i] : 0.0) +
                D[i] * A * lane(ws.dz, 3 * i + k, q);
  }
  const double F[3][3] = {{1 + H[0][0], H[0][1], H[0][2]}, {H[1][0], 1 + H[1][1], H[1][2]}, {H[2][0], H[2][1], 1 + H[2][2]}};
  // Cofactors: C = J F^-T.
  double C[3][3];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      C[i][k] = F[i1][k1] * F[i2][k2] - F[i1][k2] * F[i2][k1];
    }
  const double J = F[0][0] * C[0][0] + F[0][1] * C[0][1] + F[0][2] * C[0][2];
  ws.min_J = std::min(ws.min_J, J);
  if (!(J > 0) || !std::isfinite(J)) return false;
  double I1 = 0.0, work = 0.0;
  for (int i = 0; i < 3; ++i) {
    work += vp.body[3 * p + i] * u[i];
    for (int k = 0; k < 3; ++k) I1 += F[i][k] * F[i][k];
  }
  const Density psi = density(pb, J, I1);
  ws.energy += wq * psi.value - s * work;
  const double to_loss = A / pb.energy_scale;
  for (int i = 0; i < 3; ++i) {
    double gz = -s * vp.body[3 * p + i] * D[i];
    for (int k = 0; k < 3; ++k) {
      const double P = psi.a * F[i][k] + psi.f * C[i][k];
      if (vp.g) gz += wq * P * vp.grad_D[9 * p + 3 * i + k];
      lane(ws.gdz, 3 * i + k, q) = static_cast<float>(to_loss * wq * P * D[i]);
    }
    lane(ws.gz, i, q) = static_cast<float>(to_loss * gz);
  }
  return true;
}

void loadPoint(const Problem& pb, std::int64_t p, Workspace& ws, int q) {
  const LoadPoints& lp = pb.loads;
  const double A = pb.output_scale, s = pb.load_scale;
  for (int i = 0; i < 3; ++i) {
    const double D = lp.D ? lp.D[3 * p + i] : 1.0, f = lp.force[3 * p + i];
    ws.energy -= s * f * ((lp.g ? s * lp.g[3 * p + i] : 0.0) + D * A * lane(ws.z, i, q));
    lane(ws.gz, i, q) = static_cast<float>(-s * f * D * A / pb.energy_scale);
  }
}

void penaltyPoint(const Problem& pb, std::int64_t p, Workspace& ws, int q) {
  const PenaltyPoints& cp = pb.penalty;
  const double A = pb.output_scale, c = cp.weight / (static_cast<double>(cp.n) * A * A);
  for (int i = 0; i < 3; ++i) {
    const double r = (A * lane(ws.z, i, q) - pb.load_scale * cp.value[3 * p + i]) * cp.mask[3 * p + i];
    ws.penalty += c * r * r;
    lane(ws.gz, i, q) = static_cast<float>(2 * c * r * cp.mask[3 * p + i] * A);
  }
}

// One point set over [begin, end): forward, the per-point mechanics, backward.
template <bool Deriv, typename PointFn>
void runPoints(const Network& net, const float* x, std::int64_t begin, std::int64_t end, bool backward,
               Workspace& ws, const PointFn& point) {
  for (std::int64_t p0 = begin; p0 < end && ws.admissible; p0 += kChunk) {
    const int m = static_cast<int>(std::min<std::int64_t>(kChunk, end - p0));
    forwardChunk<Deriv>(net, x, p0, m, ws);
    std::fill(ws.gz.begin(), ws.gz.end(), v16{});
    std::fill(ws.gdz.begin(), ws.gdz.end(), v16{});
    for (int q = 0; q < m; ++q)
      if (!point(p0 + q, q)) ws.admissible = false;
    if (backward && ws.admissible) backwardChunk<Deriv>(net, ws);
  }
}

}  // namespace

Result energyAndGradient(const Network& net, const Problem& pb, const Gradient* gradient, int threads) {
  threads = std::max(1, threads);
  std::vector<Workspace> spaces(threads, Workspace(net));
  const bool back = gradient != nullptr;
  // Each set split into contiguous ranges, one per thread.
  const auto run = [&](std::int64_t n, const auto& body) {
    parallelChunks(static_cast<long>(n), threads, [&](int t, long begin, long end) { body(spaces[t], begin, end); });
  };
  run(pb.volume.n, [&](Workspace& ws, std::int64_t b, std::int64_t e) {
    runPoints<true>(net, pb.volume.x, b, e, back, ws, [&](std::int64_t p, int q) { return volumePoint(pb, p, ws, q); });
  });
  run(pb.loads.n, [&](Workspace& ws, std::int64_t b, std::int64_t e) {
    runPoints<false>(net, pb.loads.x, b, e, back, ws, [&](std::int64_t p, int q) { return loadPoint(pb, p, ws, q), true; });
  });
  run(pb.penalty.n, [&](Workspace& ws, std::int64_t b, std::int64_t e) {
    runPoints<false>(net, pb.penalty.x, b, e, back, ws,
                     [&](std::int64_t p, int q) { return penaltyPoint(pb, p, ws, q), true; });
  });
  Result r;
  r.min_J = pb.volume.n > 0 ? std::numeric_limits<double>::infinity() : 1.0;
  r.admissible = true;
  double penalty = 0.0;
  for (const Workspace& ws : spaces) {
    r.energy += ws.energy;
    penalty += ws.penalty;
    r.min_J = std::min(r.min_J, ws.min_J);
    r.admissible = r.admissible && ws.admissible;
  }
  r.loss = r.energy / pb.energy_scale + penalty;
  r.admissible = r.admissible && std::isfinite(r.loss);
  if (!back || !r.admissible) return r;
  for (int l = 0; l <= net.depth; ++l) {
    const std::size_t nw = spaces[0].gw[l].size(), nb = spaces[0].gb[l].size();
    for (std::size_t i = 0; i < nw; ++i) {
      double s = 0.0;
      for (const Workspace& ws : spaces) s += laneSum(ws.gw[l][i]);
      gradient->weights[l][i] = static_cast<float>(s);
    }
    for (std::size_t i = 0; i < nb; ++i) {
      double s = 0.0;
      for (const Workspace& ws : spaces) s += laneSum(ws.gb[l][i]);
      gradient->biases[l][i] = static_cast<float>(s);
    }
  }
  return r;
}

}  // namespace demnerf::mechanics::mlp_kernel
