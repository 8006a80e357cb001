#pragma once
// Small bias-free MLP kernels on contiguous row batches (a few hundred rows at a time, so the
// activations stay in cache): forward with fused ReLU, input gradient, weight gradient.

#include <cstdint>
#include <random>
#include <vector>

namespace demnerf::nerf {

/// Layer widths dims[0] -> dims[1] -> ... -> dims.back(); layer l's weights are a row-major
/// dims[l] x dims[l+1] block at offset(l) of one flat vector (out_row = in_row * W).
struct MlpLayout {
  std::vector<int> dims;

  int layers() const { return static_cast<int>(dims.size()) - 1; }
  std::int64_t offset(int layer) const;
  std::int64_t parameterCount() const { return offset(layers()); }
  /// Xavier-uniform weights, as tiny-cuda-nn initialises its networks.
  void initialize(std::vector<float>& weights, std::mt19937_64& rng) const;
};

/// out[n x O] = in[n x I] * W[I x O], then max(0, .) when relu.
void matmulRows(const float* in, std::int64_t n, int in_dims, const float* weights, int out_dims, float* out,
                bool relu);
/// grad_weights[I x O] += in[n x I]^T * grad_out[n x O].
void accumulateWeightGrad(const float* in, std::int64_t n, int in_dims, const float* grad_out, int out_dims,
                          float* grad_weights);
/// Transposes a rows x cols row-major matrix (for the input-gradient product).
void transpose(const float* m, int rows, int cols, float* out);

}  // namespace demnerf::nerf
