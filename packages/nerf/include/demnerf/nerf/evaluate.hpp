#pragma once
// Held-out quality of a model: PSNR and SSIM of its renders against a dataset split.

#include <functional>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/nerf/renderer.hpp"

namespace demnerf::nerf {

struct Evaluation {
  double psnr = 0;  ///< mean over views of per-view PSNR (dB)
  double ssim = 0;
  int views = 0;
  double seconds_per_view = 0;
  double samples_per_pixel = 0;  ///< field samples the renders marched, per pixel (load-independent cost)
  std::vector<double> view_psnr;
};

/// Ground truth with alpha is composited over the model's background, as the render is.
/// `on_view` (optional) sees each render with its frame index.
Evaluation evaluate(const NerfModel& model, const std::vector<core::Frame>& frames, bool compute_ssim = true,
                    const std::function<void(int, const RenderedImage&)>& on_view = {});

}  // namespace demnerf::nerf
