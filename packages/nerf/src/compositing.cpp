#include "demnerf/nerf/compositing.hpp"

#include <ATen/Parallel.h>

#include <cmath>

namespace demnerf::nerf {

void compositeForward(const CompositeInputs& in, const CompositeOutputs& out) {
  at::parallel_for(0, in.rays, 256, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t r = begin; r < end; ++r) {
      float transmittance = 1.0f, c[3] = {0, 0, 0}, depth = 0.0f;
      for (std::int64_t i = in.ray_offsets[r]; i < in.ray_offsets[r + 1]; ++i) {
        if (transmittance < in.min_transmittance) break;
        const float alpha = 1.0f - std::exp(-in.sigma[i] * in.dt[i]);
        const float w = transmittance * alpha;
        for (int k = 0; k < 3; ++k) c[k] += w * in.rgb[3 * i + k];
        depth += w * in.t[i];
        transmittance *= 1.0f - alpha;
      }
      for (int k = 0; k < 3; ++k) {
        out.color[3 * r + k] = c[k] + (in.background ? transmittance * in.background[3 * r + k] : 0.0f);
      }
      out.opacity[r] = 1.0f - transmittance;
      out.depth[r] = depth;
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
      float transmittance = 1.0f, c[3] = {0, 0, 0}, depth = 0.0f;
      bool stopped = false;
      for (std::int64_t i = in.ray_offsets[r]; i < in.ray_offsets[r + 1]; ++i) {
        if (stopped || transmittance < in.min_transmittance) {
          stopped = true;
          grad_sigma[i] = 0.0f;
          for (int k = 0; k < 3; ++k) grad_rgb[3 * i + k] = 0.0f;
          continue;
        }
        const float alpha = 1.0f - std::exp(-in.sigma[i] * in.dt[i]);
        const float w = transmittance * alpha;
        const float* ci = in.rgb + 3 * i;
        for (int k = 0; k < 3; ++k) c[k] += w * ci[k];
        depth += w * in.t[i];
        const float t_next = transmittance * (1.0f - alpha);
        float g = 0.0f;
        for (int k = 0; k < 3; ++k) {
          g += gc[k] * (t_next * ci[k] - (fwd.color[3 * r + k] - c[k]));
          grad_rgb[3 * i + k] = gc[k] * w;
        }
        g += gd * (t_next * in.t[i] - (fwd.depth[r] - depth));
        g += ga * t_final;
        grad_sigma[i] = g * in.dt[i];
        transmittance = t_next;
      }
    }
  });
}

}  // namespace demnerf::nerf
