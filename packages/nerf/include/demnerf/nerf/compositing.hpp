#pragma once
// Volume rendering (emission-absorption compositing) of samples along rays, with a fused
// per-ray backward pass. Samples of ray r are [ray_offsets[r], ray_offsets[r+1]), front to back.

#include <cmath>
#include <cstdint>

namespace demnerf::nerf {

/// The emission-absorption accumulation of one ray, front to back. Every renderer and the
/// trainer composite through it, so they agree on every sample's weight.
struct RayAccum {
  float transmittance = 1.0f, color[3] = {0, 0, 0}, depth = 0.0f;
  /// Adds the sample behind those added so far; returns its weight (transmittance x alpha).
  float add(float sigma, float dt, const float* rgb, float t) {
    const float alpha = 1.0f - std::exp(-sigma * dt);
    const float w = transmittance * alpha;
    for (int k = 0; k < 3; ++k) color[k] += w * rgb[k];
    depth += w * t;
    transmittance *= 1.0f - alpha;
    return w;
  }
  /// The ray's colour over the background (null: black).
  void finish(const float* background, float* out_color) const {
    for (int k = 0; k < 3; ++k) out_color[k] = color[k] + (background ? transmittance * background[k] : 0.0f);
  }
};

/// Colour part of d(loss)/d(sigma_i) / dt_i for sample i: what it adds in front of the light
/// behind it minus that light (total colour minus the colour accumulated up to and with i).
/// grad_color: d(loss)/d(ray colour); t_next: transmittance after i.
inline float colorSigmaGradient(const float* grad_color, const float* rgb, float t_next, const float* total_color,
                                const float* color_upto) {
  float g = 0.0f;
  for (int k = 0; k < 3; ++k) g += grad_color[k] * (t_next * rgb[k] - (total_color[k] - color_upto[k]));
  return g;
}

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
