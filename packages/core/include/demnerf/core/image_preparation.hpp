#pragma once
// Turns a camera image into a training view: RGBA float, bounded size, and the object isolated
// from a single-colour backdrop when the image carries no alpha.

#include <opencv2/core.hpp>

#include "demnerf/core/camera.hpp"

namespace demnerf::core {

/// A backdrop colour: pixels within `tolerance` (Euclidean, RGB in [0, 1]) become transparent.
struct ColourKey {
  cv::Vec3f color{0, 0, 0};
  double tolerance = 0.1;
};

/// Downscales (INTER_AREA) so the longer side is at most `max_side`, adjusting the intrinsics.
/// Images already small enough are returned as they are.
cv::Mat fitToSize(const cv::Mat& rgba, int max_side, PinholeCamera& camera);

/// Sets alpha to 0 on the backdrop. Expects CV_32FC4.
void applyColourKey(cv::Mat& rgba, const ColourKey& key);

}  // namespace demnerf::core
