#include "demnerf/nerf/compositing.hpp"

#include <ATen/Parallel.h>

#include <cmath>

namespace demnerf::nerf {

void compositeForward(const CompositeInputs& in, const CompositeOutputs& out) {
  at::parallel_for(0, in.rays, 256, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t r = begin; r < end; ++r) {
      RayAccum a;
      for (std::int64_t i = in.ray_offsets[r]; i < in.ray_offsets[r + 1]; ++i) {
        if (a.transmittance < in.min_transmittance) break;
        a.add(in.sigma[i], in.dt[i], in.rgb + 3 * i, in.t[i]);
      }
      a.finish(in.background ? in.background + 3 * r : nullptr, out.color + 3 * r);
      out.opacity[r] = 1.0f - a.transmittance;
      out.depth[r] = a.depth;
    }
  });
}

void compositeBackward(const CompositeInputs& in, const CompositeOutputs& fwd, const float* grad_color,
                       const float* grad_opacity, const float* grad_depth, float* grad_sigma, float* grad_rgb) {
  at::parallel_for(0, in.rays, 256, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t r = begin; r < end; ++r) {
      const float gc[3] = {grad_color ? grad_color[3 * r] : 0.0f, grad_color ? grad_color[3 * r + 1] : 0.0f,
                           grad_color ? grad_color[3 * r + 2] : 0.0f};
      const float ga = grad_opacity ? grad_opacity[r] : 0.0f;
      const float gd = grad_depth ? grad_depth[r] : 0.0f;
      const float t_final = 1.0f - fwd.opacity[r];
      // What lies behind sample i (later samples plus background) is total minus the
      // running sum up to i: one pass, no per-ray buffers.
      RayAccum a;
      bool stopped = false;
      for (std::int64_t i = in.ray_offsets[r]; i < in.ray_offsets[r + 1]; ++i) {
        if (stopped || a.transmittance < in.min_transmittance) {
          stopped = true;
          grad_sigma[i] = 0.0f;
          for (int k = 0; k < 3; ++k) grad_rgb[3 * i + k] = 0.0f;
          continue;
        }
        const float w = a.add(in.sigma[i], in.dt[i], in.rgb + 3 * i, in.t[i]);
        float g = colorSigmaGradient(gc, in.rgb + 3 * i, a.transmittance, fwd.color + 3 * r, a.color);
        for (int k = 0; k < 3; ++k) grad_rgb[3 * i + k] = gc[k] * w;
        g += gd * (a.transmittance * in.t[i] - (fwd.depth[r] - a.depth));
        g += ga * t_final;
        grad_sigma[i] = g * in.dt[i];
      }
    }
  });
}

}  // namespace demnerf::nerf
