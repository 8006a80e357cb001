#pragma once
// Many RGBA views tiled into one image, to look at a dataset at a glance.

#include <opencv2/core.hpp>
#include <vector>

namespace demnerf::render {

/// Tiles CV_32FC4 RGBA images (all the same size) into rows of `columns`, each composited over
/// `background` (RGB in [0, 1]) with a `gap`-pixel border; returns CV_32FC3 RGB.
cv::Mat makeContactSheet(const std::vector<cv::Mat>& images, int columns,
                         const cv::Vec3f& background = cv::Vec3f(1.0f, 1.0f, 1.0f), int gap = 2);

}  // namespace demnerf::render
