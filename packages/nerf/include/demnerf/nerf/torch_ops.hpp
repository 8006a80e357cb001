#pragma once
// LibTorch autograd wrappers around the hand-written kernels, for code that composes the
// encoding or the compositor with other torch operations (and for gradient checks).

#include <torch/torch.h>

#include "demnerf/nerf/hash_encoding.hpp"

namespace demnerf::nerf {

/// positions [N,3] (unit cube), table [total_entries * features] -> [N, levels * features].
/// float32 CPU tensors; gradients for the table and the positions.
torch::Tensor hashEncode(const torch::Tensor& positions, const torch::Tensor& table, const HashGridLayout& layout);

struct VolumeRenderResult {
  torch::Tensor color;    ///< [R,3], background included
  torch::Tensor opacity;  ///< [R]
  torch::Tensor depth;    ///< [R]
};

/// Composites samples (sigma [S], rgb [S,3], dt [S], t [S]) of rays given by ray_offsets
/// (int64 [R+1]) over background [R,3]; differentiable in sigma and rgb (fused backward).
VolumeRenderResult volumeRender(const torch::Tensor& sigma, const torch::Tensor& rgb, const torch::Tensor& dt,
                                const torch::Tensor& t, const torch::Tensor& ray_offsets,
                                const torch::Tensor& background, double min_transmittance = 0.0);

}  // namespace demnerf::nerf
