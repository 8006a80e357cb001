#pragma once
// Volume rendering (emission-absorption compositing) of samples along rays, with a fused
// per-ray backward pass. Samples of ray r are [ray_offsets[r], ray_offsets[r+1]), front to back.

#include <cstdint>

namespace demnerf::nerf {

struct CompositeInputs {
  const float* sigma;              ///< [S] density (1/m)
  const float* rgb;                ///< [S x 3]
  const float* dt;                 ///< [S] segment lengths (m)
  const float* t;                  ///< [S] distances along the ray (m), for depth
  const std::int64_t* ray_offsets; ///< [R + 1]
  std::int64_t rays;
  const float* background;         ///< [R x 3] or null (black)
  float min_transmittance;         ///< a ray stops once its transmittance drops below this
};

struct CompositeOutputs {
  float* color;    ///< [R x 3], background included
  float* opacity;  ///< [R]
  float* depth;    ///< [R], opacity-weighted distance (not normalised)
};

/// Threaded over rays.
void compositeForward(const CompositeInputs& in, const CompositeOutputs& out);
/// Given the forward outputs and d(loss)/d(outputs) (any may be null), writes
/// d(loss)/d(sigma) [S] and d(loss)/d(rgb) [S x 3]; samples past the stop get zero.
void compositeBackward(const CompositeInputs& in, const CompositeOutputs& forward_out, const float* grad_color,
                       const float* grad_opacity, const float* grad_depth, float* grad_sigma, float* grad_rgb);

}  // namespace demnerf::nerf
