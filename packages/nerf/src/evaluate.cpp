#include "demnerf/nerf/evaluate.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/core/metrics.hpp"

namespace demnerf::nerf {

Evaluation evaluate(const NerfModel& model, const std::vector<core::Frame>& frames, bool compute_ssim,
                    const std::function<void(int, const RenderedImage&)>& on_view) {
  Evaluation result;
  if (frames.empty()) throw core::Error("evaluation needs at least one view; the split is empty");
  const auto& b = model.config().background;
  const cv::Vec3f background(static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2]));
  double seconds = 0, samples = 0, pixels = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const core::Frame& frame = frames[i];
    if (frame.rgba.empty()) throw core::Error("frame '" + frame.file_path + "' has no image loaded to compare with");
    const RenderedImage image = renderImage(model, frame.camera, frame.world_from_camera);
    seconds += image.seconds;
    samples += static_cast<double>(image.samples);
    pixels += static_cast<double>(frame.camera.width) * frame.camera.height;
    const cv::Mat truth = core::compositeOver(frame.rgba, background);
    const double p = core::psnr(image.color, truth);
    result.view_psnr.push_back(p);
    result.psnr += std::isfinite(p) ? p : 100.0;
    if (compute_ssim) result.ssim += core::ssim(image.color, truth);
    if (on_view) on_view(static_cast<int>(i), image);
  }
  result.views = static_cast<int>(frames.size());
  result.psnr /= result.views;
  result.ssim /= result.views;
  result.seconds_per_view = seconds / result.views;
  result.samples_per_pixel = samples / pixels;
  return result;
}

}  // namespace demnerf::nerf
