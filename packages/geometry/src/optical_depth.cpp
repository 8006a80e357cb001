#include "demnerf/geometry/optical_depth.hpp"

#include <algorithm>
#include <limits>

namespace demnerf::geometry {

DensityGrid axisOpticalDepth(const DensityGrid& density) {
  density.validate();
  DensityGrid depth = density;
  std::fill(depth.values.begin(), depth.values.end(), std::numeric_limits<float>::infinity());
  const Eigen::Vector3i& n = density.dims;
  // Sweep each axis both ways; the line through (i, j, k) along axis a has stride strides[a].
  const std::size_t strides[3] = {1, static_cast<std::size_t>(n.x()), static_cast<std::size_t>(n.x()) * n.y()};
  for (int axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    const double h = density.spacing[axis];
    const int length = n[axis];
    for (int v = 0; v < n[c]; ++v) {
      for (int u = 0; u < n[b]; ++u) {
        const std::size_t start = u * strides[b] + v * strides[c];
        for (int direction : {+1, -1}) {
          // From the empty node just outside the border (sigma 0, tau 0) inward.
          double tau = 0.0, previous = 0.0;
          for (int s = 0; s < length; ++s) {
            const int m = direction > 0 ? s : length - 1 - s;
            const std::size_t id = start + m * strides[axis];
            const double sigma = std::max(0.0f, density.values[id]);  // negative density is none
            tau += 0.5 * (previous + sigma) * h;
            previous = sigma;
            depth.values[id] = std::min(depth.values[id], static_cast<float>(tau));
          }
        }
      }
    }
  }
  return depth;
}

}  // namespace demnerf::geometry
