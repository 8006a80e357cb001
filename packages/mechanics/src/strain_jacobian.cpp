// The Gauss-Newton metric's rows by hand (strain_jacobian.hpp). Per point: the network forward
// with its X-derivatives carried (h_l, T_l = dh_l / dX), the deformation gradient F = I + grad u of
// u = s g + D o z, then per row a symmetric cotangent Ebar on the Green strain E (the row is
// Ebar : dE), taken back to F (Fbar = F Ebar, as dE = sym(F^T dF)), to the output z and its
// X-derivative Z, and through the layers: at a tanh layer h' = tanh(a), T' = sigma'(a) W T, with
// sigma' = 1 - h'^2 and d sigma' / da = -2 h' sigma'.
#include "strain_jacobian.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "parallel_for.hpp"

namespace demnerf::mechanics::strain_rows {

namespace {

constexpr int kMandel[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};

// The network in double, with each layer's input size and its columns' offsets in a row of A.
struct Layers {
  int depth = 0, width = 0;
  double center[3] = {0, 0, 0}, inv_half[3] = {1, 1, 1}, out = 1.0;
  std::vector<std::vector<double>> W, b;
  std::vector<int> in, out_size;
  std::vector<std::int64_t> at_W, at_b;
  std::int64_t params = 0;

  Layers(const mlp_kernel::Network& net, double output_scale) : depth(net.depth), width(net.width), out(output_scale) {
    for (int k = 0; k < 3; ++k) center[k] = net.center[k], inv_half[k] = net.inv_half[k];
    for (int l = 0; l <= depth; ++l) {
      in.push_back(l == 0 ? 3 : width);
      out_size.push_back(l == depth ? 3 : width);
      W.emplace_back(net.weights[l], net.weights[l] + in[l] * out_size[l]);
      b.emplace_back(net.biases[l], net.biases[l] + out_size[l]);
      at_W.push_back(params);
      at_b.push_back(params + in[l] * out_size[l]);
      params += (in[l] + 1) * out_size[l];
    }
  }
};

// One point's forward values and a row's cotangents (a thread's scratch, reused point to point).
struct PointState {
  std::vector<std::vector<double>> h, T, P, sp;  // h_l [in_l], T_l [in_l x 3], P_l = W_l T_l, sigma'_l
  std::vector<double> hb, Tb, hb_next, Tb_next, ab, Pb;
  double z[3], Z[3][3], F[3][3];

  explicit PointState(const Layers& n) : h(n.depth + 1), T(n.depth + 1), P(n.depth), sp(n.depth) {
    for (int l = 0; l <= n.depth; ++l) {
      h[l].resize(n.in[l]);
      T[l].resize(3 * n.in[l]);
      if (l < n.depth) P[l].resize(3 * n.width), sp[l].resize(n.width);
    }
    for (auto* v : {&hb, &hb_next, &ab}) v->resize(n.width);
    for (auto* v : {&Tb, &Tb_next, &Pb}) v->resize(3 * n.width);
  }
};

// The network's value z and X-derivative Z at x, the layers' values kept for the backward pass.
void forward(const Layers& n, const float* x, PointState& s) {
  for (int k = 0; k < 3; ++k) {
    s.h[0][k] = (x[k] - n.center[k]) * n.inv_half[k];
    for (int m = 0; m < 3; ++m) s.T[0][3 * m + k] = m == k ? n.inv_half[k] : 0.0;
  }
  for (int l = 0; l < n.depth; ++l) {
    const int in = n.in[l];
    for (int j = 0; j < n.width; ++j) {
      const double* w = &n.W[l][j * in];
      double a = n.b[l][j], p[3] = {0, 0, 0};
      for (int m = 0; m < in; ++m) {
        a += w[m] * s.h[l][m];
        for (int k = 0; k < 3; ++k) p[k] += w[m] * s.T[l][3 * m + k];
      }
      const double hn = std::tanh(a), sp = 1.0 - hn * hn;
      s.h[l + 1][j] = hn;
      s.sp[l][j] = sp;
      for (int k = 0; k < 3; ++k) s.P[l][3 * j + k] = p[k], s.T[l + 1][3 * j + k] = sp * p[k];
    }
  }
  const int L = n.depth, in = n.in[L];
  for (int i = 0; i < 3; ++i) {
    const double* w = &n.W[L][i * in];
    double z = n.b[L][i], dz[3] = {0, 0, 0};
    for (int j = 0; j < in; ++j) {
      z += w[j] * s.h[L][j];
      for (int k = 0; k < 3; ++k) dz[k] += w[j] * s.T[L][3 * j + k];
    }
    s.z[i] = n.out * z;
    for (int k = 0; k < 3; ++k) s.Z[i][k] = n.out * dz[k];
  }
}

// Writes the row Ebar : dE (Ebar symmetric) into `row`: Fbar = F Ebar, then zbar_i = sum_k Fbar_ik
// dD_ik and Zbar_ik = Fbar_ik D_i, then back through the output layer and the tanh layers.
void backward(const Layers& n, const double (&Ebar)[3][3], const float* D, const float* dD, PointState& s,
              float* row) {
  double zb[3], Zb[3][3];
  for (int i = 0; i < 3; ++i) {
    zb[i] = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double Fb = s.F[i][0] * Ebar[0][k] + s.F[i][1] * Ebar[1][k] + s.F[i][2] * Ebar[2][k];
      zb[i] += Fb * dD[3 * i + k];
      Zb[i][k] = n.out * Fb * D[i];
    }
    zb[i] *= n.out;
  }
  const int L = n.depth, inL = n.in[L];
  for (int j = 0; j < inL; ++j) s.hb[j] = 0.0, s.Tb[3 * j] = s.Tb[3 * j + 1] = s.Tb[3 * j + 2] = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double* w = &n.W[L][i * inL];
    float* gw = row + n.at_W[L] + i * inL;
    row[n.at_b[L] + i] = static_cast<float>(zb[i]);
    for (int j = 0; j < inL; ++j) {
      const double* T = &s.T[L][3 * j];
      gw[j] = static_cast<float>(zb[i] * s.h[L][j] + Zb[i][0] * T[0] + Zb[i][1] * T[1] + Zb[i][2] * T[2]);
      s.hb[j] += w[j] * zb[i];
      for (int k = 0; k < 3; ++k) s.Tb[3 * j + k] += w[j] * Zb[i][k];
    }
  }
  for (int l = L - 1; l >= 0; --l) {
    const int in = n.in[l];
    for (int j = 0; j < n.width; ++j) {
      const double* Tb = &s.Tb[3 * j];
      const double* P = &s.P[l][3 * j];
      const double sp = s.sp[l][j], spb = Tb[0] * P[0] + Tb[1] * P[1] + Tb[2] * P[2];
      s.ab[j] = sp * (s.hb[j] - 2.0 * s.h[l + 1][j] * spb);
      for (int k = 0; k < 3; ++k) s.Pb[3 * j + k] = sp * Tb[k];
      row[n.at_b[l] + j] = static_cast<float>(s.ab[j]);
      float* gw = row + n.at_W[l] + j * in;
      for (int m = 0; m < in; ++m) {
        const double* T = &s.T[l][3 * m];
        gw[m] = static_cast<float>(s.ab[j] * s.h[l][m] + s.Pb[3 * j] * T[0] + s.Pb[3 * j + 1] * T[1] +
                                   s.Pb[3 * j + 2] * T[2]);
      }
    }
    if (l == 0) break;
    for (int m = 0; m < in; ++m) {
      double hb = 0.0, tb[3] = {0, 0, 0};
      for (int j = 0; j < n.width; ++j) {
        const double w = n.W[l][j * in + m];
        hb += w * s.ab[j];
        for (int k = 0; k < 3; ++k) tb[k] += w * s.Pb[3 * j + k];
      }
      s.hb_next[m] = hb;
      for (int k = 0; k < 3; ++k) s.Tb_next[3 * m + k] = tb[k];
    }
    std::swap(s.hb, s.hb_next);
    std::swap(s.Tb, s.Tb_next);
  }
}

// The inverse of a 3 x 3 matrix by cofactors; returns its determinant.
double inverse3(const double (&a)[3][3], double (&inv)[3][3]) {
  inv[0][0] = a[1][1] * a[2][2] - a[1][2] * a[2][1];
  inv[0][1] = a[0][2] * a[2][1] - a[0][1] * a[2][2];
  inv[0][2] = a[0][1] * a[1][2] - a[0][2] * a[1][1];
  inv[1][0] = a[1][2] * a[2][0] - a[1][0] * a[2][2];
  inv[1][1] = a[0][0] * a[2][2] - a[0][2] * a[2][0];
  inv[1][2] = a[0][2] * a[1][0] - a[0][0] * a[1][2];
  inv[2][0] = a[1][0] * a[2][1] - a[1][1] * a[2][0];
  inv[2][1] = a[0][1] * a[2][0] - a[0][0] * a[2][1];
  inv[2][2] = a[0][0] * a[1][1] - a[0][1] * a[1][0];
  const double det = a[0][0] * inv[0][0] + a[0][1] * inv[1][0] + a[0][2] * inv[2][0];
  for (auto& r : inv)
    for (double& v : r) v /= det;
  return det;
}

// The lower Cholesky factor L of the Neo-Hookean's tangent at F in Mandel form: dS/dE =
// lambda c (x) c + 2 (mu - lambda ln J) I_c with c = (F^T F)^-1 and (I_c)_ijkl = (c_ik c_jl +
// c_il c_jk) / 2, so that dE : (dS/dE) : dE = |L^T mandel(dE)|^2. The self-weight block's base is
// compressed by 10-15 % in volume, where this is ~50 % stiffer than the zero-strain tangent: steps
// in that metric were too long (rho < 1/4, the damping climbing to 14 x G's mean diagonal). The
// factor mu - lambda ln J is kept above mu / 10 (it falls below zero only for J > e^(mu / lambda)),
// so the metric stays positive definite.
void currentTangentFactor(const double (&F)[3][3], const Metric& m, double (&L)[6][6]) {
  double C[3][3], c[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C[i][j] = F[0][i] * F[0][j] + F[1][i] * F[1][j] + F[2][i] * F[2][j];
  inverse3(C, c);
  // det F as inverse3 rounds it (its inverse unused): a determinant written on its own contracts
  // into different fused multiply-adds, and the Levenberg-Marquardt path amplifies that last bit
  // (the NeRF T-bar grid 1/6 answer moved from -0.1064153 to -0.1064023 J).
  double Finv[3][3];
  const double lnJ = std::log(std::max(inverse3(F, Finv), 1e-12));
  const double shear = 2.0 * std::max(m.mu - m.lambda * lnJ, 0.1 * m.mu);
  double M[6][6], cm[6];
  for (int a = 0; a < 6; ++a) {
    const int i = kMandel[a][0], j = kMandel[a][1];
    const double sa = i == j ? 1.0 : std::sqrt(2.0);
    cm[a] = sa * c[i][j];
    for (int b = 0; b < 6; ++b) {
      const int k = kMandel[b][0], l = kMandel[b][1];
      const double sb = k == l ? 1.0 : std::sqrt(2.0);
      M[a][b] = sa * sb * shear * 0.5 * (c[i][k] * c[j][l] + c[i][l] * c[j][k]);
    }
  }
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) M[a][b] += m.lambda * cm[a] * cm[b];
  for (int j = 0; j < 6; ++j) {
    double d = M[j][j];
    for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
    L[j][j] = std::sqrt(d);
    for (int i = j + 1; i < 6; ++i) {
      double v = M[i][j];
      for (int k = 0; k < j; ++k) v -= L[i][k] * L[j][k];
      L[i][j] = v / L[j][j];
    }
    for (int k = j + 1; k < 6; ++k) L[j][k] = 0.0;
  }
}

// The rows' strain cotangents at one point (weight ws = w / energy_scale): L^T mandel(E) scaled
// by sqrt(ws) (current), or sqrt(lambda ws) tr E and sqrt(2 mu ws) E_ij, i <= j, off-diagonals x sqrt 2.
void rowCotangents(const Metric& m, double ws, const double (&F)[3][3], double (&Ebar)[7][3][3]) {
  for (auto& E : Ebar)
    for (auto& r : E)
      for (double& v : r) v = 0.0;
  const double root2 = std::sqrt(2.0);
  if (m.current) {
    double L[6][6];
    currentTangentFactor(F, m, L);
    for (int r = 0; r < 6; ++r)
      for (int a = 0; a < 6; ++a) {
        const int i = kMandel[a][0], j = kMandel[a][1];
        const double v = std::sqrt(ws) * L[a][r] * (i == j ? 1.0 : root2 / 2.0);
        Ebar[r][i][j] = v;
        Ebar[r][j][i] = v;
      }
    return;
  }
  for (int i = 0; i < 3; ++i) Ebar[0][i][i] = std::sqrt(m.lambda * ws);
  int r = 1;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j, ++r) {
      const double v = std::sqrt(2.0 * m.mu * ws) * (i == j ? 1.0 : root2 / 2.0);
      Ebar[r][i][j] = v;
      Ebar[r][j][i] = v;
    }
}

}  // namespace

int rowsPerPoint(const Metric& metric) { return metric.current ? 6 : 7; }

std::int64_t parameterCount(const mlp_kernel::Network& net) { return Layers(net, 1.0).params; }

void strainJacobianRows(const mlp_kernel::Network& net, const Metric& metric, const mlp_kernel::VolumePoints& points,
                        float* rows, int threads) {
  const Layers layers(net, metric.output_scale);
  const std::int64_t n = points.n, R = rowsPerPoint(metric);
  parallelFor(n, threads, [&](long begin, long end) {
    PointState s(layers);
    double Ebar[7][3][3];
    for (long q = begin; q < end; ++q) {
      forward(layers, points.x + 3 * q, s);
      const float *D = points.D + 3 * q, *dD = points.grad_D + 9 * q, *dg = points.grad_g + 9 * q;
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k)
          s.F[i][k] = (i == k ? 1.0 : 0.0) + metric.load_scale * dg[3 * i + k] + dD[3 * i + k] * s.z[i] + D[i] * s.Z[i][k];
      rowCotangents(metric, points.weight[q] / metric.energy_scale, s.F, Ebar);
      for (int r = 0; r < R; ++r) {
        const std::int64_t at = metric.current ? q * R + r : r * n + q;
        backward(layers, Ebar[r], D, dD, s, rows + at * layers.params);
      }
    }
  });
}

}  // namespace demnerf::mechanics::strain_rows
