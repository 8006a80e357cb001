#include "demnerf/nerf/mlp.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace demnerf::nerf {
namespace {

// The kernels hold 16-float vectors (GCC/Clang vector extensions: one AVX-512 register, or
// two AVX2 ones) and keep every accumulator in a register by blocking rows with template
// counts. Left to itself, GCC vectorised the earlier plain loops across the input dimension
// with shuffles (40 kB of code for the 16-wide layer) and spent more time in the 16-wide and
// 3-wide layers than in the 32-wide ones that do 2-6x their arithmetic.
typedef float v16 __attribute__((vector_size(64)));
typedef int vi16 __attribute__((vector_size(64)));

inline v16 load(const float* p) {
  v16 v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void store(float* p, v16 v) { __builtin_memcpy(p, &v, sizeof v); }
inline v16 relu(v16 v) { return reinterpret_cast<v16>(reinterpret_cast<vi16>(v) & (v > 0.0f)); }
inline float sum(v16 v) {
  float s = 0.0f;
  for (int i = 0; i < 16; ++i) s += v[i];
  return s;
}

// R rows of out[R x 16V] = in[R x I] * W[I x 16V]: R x V accumulators stay in registers,
// each weight vector is loaded once for the R rows.
template <int V, int R>
inline void rowsTimesWeights(const float* __restrict in, int I, const float* __restrict w, float* __restrict out,
                             bool apply_relu) {
  v16 acc[R][V];
#pragma GCC unroll 16
  for (int r = 0; r < R; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) acc[r][v] = v16{};
  for (int k = 0; k < I; ++k) {
    v16 wk[V];
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) wk[v] = load(w + (k * V + v) * 16);
#pragma GCC unroll 16
    for (int r = 0; r < R; ++r) {
      const float b = in[r * I + k];
#pragma GCC unroll 16
      for (int v = 0; v < V; ++v) acc[r][v] += b * wk[v];
    }
  }
#pragma GCC unroll 16
  for (int r = 0; r < R; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) store(out + (r * V + v) * 16, apply_relu ? relu(acc[r][v]) : acc[r][v]);
}

template <int V, int R>
void matmulFixed(const float* in, std::int64_t n, int I, const float* w, float* out, bool apply_relu) {
  std::int64_t r = 0;
  for (; r + R <= n; r += R) rowsTimesWeights<V, R>(in + r * I, I, w, out + r * 16 * V, apply_relu);
  for (; r < n; ++r) rowsTimesWeights<V, 1>(in + r * I, I, w, out + r * 16 * V, apply_relu);
}

// Narrow outputs (the colour layer's 3): per row, O dot products over the input in vectors.
// I must be a multiple of 16 (the caller checks).
template <int O>
void matmulNarrow(const float* __restrict in, std::int64_t n, int I, const float* __restrict w, float* __restrict out,
                  bool apply_relu) {
  float wt[O][128];  // W^T, one input row per output
  for (int k = 0; k < I; ++k)
    for (int j = 0; j < O; ++j) wt[j][k] = w[k * O + j];
  for (std::int64_t r = 0; r < n; ++r) {
    v16 acc[O];
    for (int j = 0; j < O; ++j) acc[j] = v16{};
    for (int k = 0; k < I; k += 16) {
      const v16 x = load(in + r * I + k);
      for (int j = 0; j < O; ++j) acc[j] += x * load(wt[j] + k);
    }
    for (int j = 0; j < O; ++j) {
      const float s = sum(acc[j]);
      out[r * O + j] = apply_relu ? std::max(s, 0.0f) : s;
    }
  }
}

// grad_w[k .. k+K][16V] += sum_r in[r][k .. k+K] * g[r][16V]: K x V accumulators in registers.
template <int V, int K>
inline void weightGradRows(const float* __restrict in, std::int64_t n, int I, int k, const float* __restrict g,
                           float* __restrict gw) {
  v16 acc[K][V];
#pragma GCC unroll 16
  for (int kk = 0; kk < K; ++kk)
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) acc[kk][v] = load(gw + ((k + kk) * V + v) * 16);
  for (std::int64_t r = 0; r < n; ++r) {
    v16 gr[V];
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) gr[v] = load(g + (r * V + v) * 16);
    const float* x = in + r * I + k;
#pragma GCC unroll 16
    for (int kk = 0; kk < K; ++kk) {
      const float b = x[kk];
#pragma GCC unroll 16
      for (int v = 0; v < V; ++v) acc[kk][v] += b * gr[v];
    }
  }
#pragma GCC unroll 16
  for (int kk = 0; kk < K; ++kk)
#pragma GCC unroll 16
    for (int v = 0; v < V; ++v) store(gw + ((k + kk) * V + v) * 16, acc[kk][v]);
}

template <int V, int K>
void weightGradFixed(const float* in, std::int64_t n, int I, const float* g, float* gw) {
  int k = 0;
  for (; k + K <= I; k += K) weightGradRows<V, K>(in, n, I, k, g, gw);
  for (; k < I; ++k) weightGradRows<V, 1>(in, n, I, k, g, gw);
}

// Narrow outputs: grad_w^T[j][I] += sum_r g[r][j] * in[r][:], the input row in vectors.
// I must be a multiple of 16 and at most 128 (the caller checks).
template <int O>
void weightGradNarrow(const float* __restrict in, std::int64_t n, int I, const float* __restrict g,
                      float* __restrict gw) {
  constexpr int kMaxV = 8;
  const int nv = I / 16;
  v16 acc[O][kMaxV];
  for (int j = 0; j < O; ++j)
    for (int v = 0; v < nv; ++v) acc[j][v] = v16{};
  for (std::int64_t r = 0; r < n; ++r) {
    for (int v = 0; v < nv; ++v) {
      const v16 x = load(in + r * I + 16 * v);
      for (int j = 0; j < O; ++j) acc[j][v] += g[r * O + j] * x;
    }
  }
  for (int j = 0; j < O; ++j)
    for (int v = 0; v < nv; ++v)
      for (int i = 0; i < 16; ++i) gw[(16 * v + i) * O + j] += acc[j][v][i];
}

void matmulGeneric(const float* in, std::int64_t n, int I, const float* w, int O, float* out, bool relu) {
  for (std::int64_t r = 0; r < n; ++r) {
    float* o = out + r * O;
    for (int j = 0; j < O; ++j) o[j] = 0.0f;
    for (int k = 0; k < I; ++k) {
      const float b = in[r * I + k];
      const float* wk = w + static_cast<std::int64_t>(k) * O;
      for (int j = 0; j < O; ++j) o[j] += b * wk[j];
    }
    if (relu) for (int j = 0; j < O; ++j) o[j] = std::max(o[j], 0.0f);
  }
}

void weightGradGeneric(const float* in, std::int64_t n, int I, const float* g, int O, float* gw) {
  for (std::int64_t r = 0; r < n; ++r) {
    for (int k = 0; k < I; ++k) {
      const float b = in[r * I + k];
      if (b == 0.0f) continue;
      for (int j = 0; j < O; ++j) gw[k * O + j] += b * g[r * O + j];
    }
  }
}

}  // namespace

std::int64_t MlpLayout::offset(int layer) const {
  std::int64_t total = 0;
  for (int l = 0; l < layer; ++l) total += static_cast<std::int64_t>(dims[l]) * dims[l + 1];
  return total;
}

void MlpLayout::initialize(std::vector<float>& weights, std::mt19937_64& rng) const {
  weights.assign(parameterCount(), 0.0f);
  for (int l = 0; l < layers(); ++l) {
    const float bound = std::sqrt(6.0f / static_cast<float>(dims[l] + dims[l + 1]));
    std::uniform_real_distribution<float> uniform(-bound, bound);
    float* w = weights.data() + offset(l);
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(dims[l]) * dims[l + 1]; ++i) w[i] = uniform(rng);
  }
}

void matmulRows(const float* in, std::int64_t n, int in_dims, const float* weights, int out_dims, float* out,
                bool relu) {
  switch (out_dims) {
    case 16: return matmulFixed<1, 8>(in, n, in_dims, weights, out, relu);
    case 32: return matmulFixed<2, 8>(in, n, in_dims, weights, out, relu);
    case 64: return matmulFixed<4, 4>(in, n, in_dims, weights, out, relu);
    case 128: return matmulFixed<8, 2>(in, n, in_dims, weights, out, relu);
    default: break;
  }
  if (out_dims == 3 && in_dims % 16 == 0 && in_dims <= 128) return matmulNarrow<3>(in, n, in_dims, weights, out, relu);
  matmulGeneric(in, n, in_dims, weights, out_dims, out, relu);
}

void accumulateWeightGrad(const float* in, std::int64_t n, int in_dims, const float* grad_out, int out_dims,
                          float* grad_weights) {
  switch (out_dims) {
    case 16: return weightGradFixed<1, 8>(in, n, in_dims, grad_out, grad_weights);
    case 32: return weightGradFixed<2, 4>(in, n, in_dims, grad_out, grad_weights);
    case 64: return weightGradFixed<4, 4>(in, n, in_dims, grad_out, grad_weights);
    case 128: return weightGradFixed<8, 2>(in, n, in_dims, grad_out, grad_weights);
    default: break;
  }
  if (out_dims == 3 && in_dims % 16 == 0 && in_dims <= 128) {
    return weightGradNarrow<3>(in, n, in_dims, grad_out, grad_weights);
  }
  weightGradGeneric(in, n, in_dims, grad_out, out_dims, grad_weights);
}

void transpose(const float* m, int rows, int cols, float* out) {
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out[c * rows + r] = m[r * cols + c];
}

}  // namespace demnerf::nerf
