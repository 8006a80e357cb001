#include "demnerf/nerf/mlp.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace demnerf::nerf {
namespace {

// Four rows share each loaded weight row; with O known at compile time the accumulators
// are 4 x O floats that the compiler keeps in vector registers (O = 64: 16 AVX-512 regs).
template <int O>
void matmulFixed(const float* __restrict in, std::int64_t n, int I, const float* __restrict w,
                 float* __restrict out, bool relu) {
  std::int64_t r = 0;
  for (; r + 4 <= n; r += 4) {
    float a0[O], a1[O], a2[O], a3[O];
    for (int j = 0; j < O; ++j) a0[j] = a1[j] = a2[j] = a3[j] = 0.0f;
    const float* x0 = in + r * I;
    const float* x1 = x0 + I;
    const float* x2 = x1 + I;
    const float* x3 = x2 + I;
    for (int k = 0; k < I; ++k) {
      const float* wk = w + static_cast<std::int64_t>(k) * O;
      const float b0 = x0[k], b1 = x1[k], b2 = x2[k], b3 = x3[k];
#pragma GCC unroll 16
      for (int j = 0; j < O; ++j) {
        a0[j] += b0 * wk[j];
        a1[j] += b1 * wk[j];
        a2[j] += b2 * wk[j];
        a3[j] += b3 * wk[j];
      }
    }
    float* o = out + r * O;
    if (relu) {
      for (int j = 0; j < O; ++j) {
        o[j] = std::max(a0[j], 0.0f);
        o[O + j] = std::max(a1[j], 0.0f);
        o[2 * O + j] = std::max(a2[j], 0.0f);
        o[3 * O + j] = std::max(a3[j], 0.0f);
      }
    } else {
      for (int j = 0; j < O; ++j) {
        o[j] = a0[j];
        o[O + j] = a1[j];
        o[2 * O + j] = a2[j];
        o[3 * O + j] = a3[j];
      }
    }
  }
  for (; r < n; ++r) {
    float a[O];
    for (int j = 0; j < O; ++j) a[j] = 0.0f;
    for (int k = 0; k < I; ++k) {
      const float b = in[r * I + k];
      const float* wk = w + static_cast<std::int64_t>(k) * O;
      for (int j = 0; j < O; ++j) a[j] += b * wk[j];
    }
    for (int j = 0; j < O; ++j) out[r * O + j] = relu ? std::max(a[j], 0.0f) : a[j];
  }
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

// grad_w[k][:] += sum_r in[r][k] * g[r][:], four k rows at a time held in registers.
template <int O>
void weightGradFixed(const float* __restrict in, std::int64_t n, int I, const float* __restrict g,
                     float* __restrict gw) {
  int k = 0;
  for (; k + 4 <= I; k += 4) {
    float a0[O], a1[O], a2[O], a3[O];
    for (int j = 0; j < O; ++j) {
      a0[j] = gw[(k + 0) * O + j];
      a1[j] = gw[(k + 1) * O + j];
      a2[j] = gw[(k + 2) * O + j];
      a3[j] = gw[(k + 3) * O + j];
    }
    for (std::int64_t r = 0; r < n; ++r) {
      const float* x = in + r * I + k;
      const float* gr = g + r * O;
      const float b0 = x[0], b1 = x[1], b2 = x[2], b3 = x[3];
#pragma GCC unroll 16
      for (int j = 0; j < O; ++j) {
        a0[j] += b0 * gr[j];
        a1[j] += b1 * gr[j];
        a2[j] += b2 * gr[j];
        a3[j] += b3 * gr[j];
      }
    }
    for (int j = 0; j < O; ++j) {
      gw[(k + 0) * O + j] = a0[j];
      gw[(k + 1) * O + j] = a1[j];
      gw[(k + 2) * O + j] = a2[j];
      gw[(k + 3) * O + j] = a3[j];
    }
  }
  for (; k < I; ++k) {
    float a[O];
    for (int j = 0; j < O; ++j) a[j] = gw[k * O + j];
    for (std::int64_t r = 0; r < n; ++r) {
      const float b = in[r * I + k];
      for (int j = 0; j < O; ++j) a[j] += b * g[r * O + j];
    }
    for (int j = 0; j < O; ++j) gw[k * O + j] = a[j];
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
    case 16: return matmulFixed<16>(in, n, in_dims, weights, out, relu);
    case 32: return matmulFixed<32>(in, n, in_dims, weights, out, relu);
    case 64: return matmulFixed<64>(in, n, in_dims, weights, out, relu);
    case 128: return matmulFixed<128>(in, n, in_dims, weights, out, relu);
    default: return matmulGeneric(in, n, in_dims, weights, out_dims, out, relu);
  }
}

void accumulateWeightGrad(const float* in, std::int64_t n, int in_dims, const float* grad_out, int out_dims,
                          float* grad_weights) {
  switch (out_dims) {
    case 16: return weightGradFixed<16>(in, n, in_dims, grad_out, grad_weights);
    case 32: return weightGradFixed<32>(in, n, in_dims, grad_out, grad_weights);
    case 64: return weightGradFixed<64>(in, n, in_dims, grad_out, grad_weights);
    case 128: return weightGradFixed<128>(in, n, in_dims, grad_out, grad_weights);
    default: return weightGradGeneric(in, n, in_dims, grad_out, out_dims, grad_weights);
  }
}

void transpose(const float* m, int rows, int cols, float* out) {
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out[c * rows + r] = m[r * cols + c];
}

}  // namespace demnerf::nerf
