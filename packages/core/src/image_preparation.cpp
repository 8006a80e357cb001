#include "demnerf/core/image_preparation.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/error.hpp"

namespace demnerf::core {

cv::Mat fitToSize(const cv::Mat& rgba, int max_side, PinholeCamera& camera) {
  const int longer = std::max(rgba.cols, rgba.rows);
  if (max_side <= 0 || longer <= max_side) return rgba;
  camera = camera.downscaled(static_cast<double>(longer) / max_side);
  cv::Mat small;
  cv::resize(rgba, small, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  return small;
}

void applyColourKey(cv::Mat& rgba, const ColourKey& key) {
  if (rgba.type() != CV_32FC4) throw Error("applyColourKey: expects a CV_32FC4 image");
  const float tolerance_squared = static_cast<float>(key.tolerance * key.tolerance);
  rgba.forEach<cv::Vec4f>([&](cv::Vec4f& pixel, const int*) {
    const float dr = pixel[0] - key.color[0], dg = pixel[1] - key.color[1], db = pixel[2] - key.color[2];
    if (dr * dr + dg * dg + db * db <= tolerance_squared) pixel[3] = 0.0f;
  });
}

}  // namespace demnerf::core
