#pragma once
// A scalar field sampled on a regular grid (the NeRF's density, exported for mesh extraction).

#include <Eigen/Core>
#include <string>
#include <vector>

namespace demnerf::geometry {

/// values[(k * dims.y() + j) * dims.x() + i] is the field at origin + (i, j, k) * spacing.
struct DensityGrid {
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  std::vector<float> values;

  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * dims.y() + j) * dims.x() + i;
  }
  float at(int i, int j, int k) const { return values[index(i, j, k)]; }
  Eigen::Vector3d node(int i, int j, int k) const {
    return origin + Eigen::Vector3d(i, j, k).cwiseProduct(spacing);
  }
  /// Throws core::Error when dims < 2, spacing <= 0, sizes disagree or a value is NaN.
  void validate(const std::string& what = "density grid") const;
};

/// The density at which one grid step of length `step` reaches opacity `alpha`
/// (1 - exp(-sigma * step) = alpha): a threshold tied to what the NeRF renders as solid.
double densityForOpacity(double alpha, double step);

}  // namespace demnerf::geometry
