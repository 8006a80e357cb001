#include "demnerf/geometry/density_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {

DensityGrid sampleDensityGrid(const DensityFunction& density, const Eigen::AlignedBox3d& box, int resolution) {
  std::ostringstream problem;
  if (!density) {
    problem << "sampleDensityGrid: the density function is empty";
  } else if (resolution < 2 || resolution > 2048) {
    problem << "density grid resolution must be in [2, 2048], got " << resolution;
  } else if (box.isEmpty() || !box.min().allFinite() || !box.max().allFinite() || !(box.sizes().minCoeff() > 0)) {
    problem << "density grid box (" << box.min().transpose() << ") - (" << box.max().transpose()
            << ") must be finite with positive size";
  }
  if (!problem.str().empty()) throw core::Error(problem.str());
  const double cell = box.sizes().maxCoeff() / resolution;
  DensityGrid grid;
  grid.spacing = Eigen::Vector3d::Constant(cell);
  for (int a = 0; a < 3; ++a) {
    // Whole cells covering the box, centred on it.
    grid.dims[a] = std::max(2, static_cast<int>(std::ceil(box.sizes()[a] / cell - 1e-9)));
    grid.origin[a] = box.center()[a] - 0.5 * grid.dims[a] * cell + 0.5 * cell;
  }
  const std::size_t slice = static_cast<std::size_t>(grid.dims.x()) * grid.dims.y();
  grid.values.resize(slice * grid.dims.z());
  std::vector<float> points(3 * slice);
  for (int k = 0; k < grid.dims.z(); ++k) {
    std::size_t n = 0;
    for (int j = 0; j < grid.dims.y(); ++j) {
      for (int i = 0; i < grid.dims.x(); ++i) {
        const Eigen::Vector3d p = grid.node(i, j, k);
        for (int a = 0; a < 3; ++a) points[n++] = static_cast<float>(p[a]);
      }
    }
    density(points.data(), static_cast<std::int64_t>(slice), grid.values.data() + slice * k);
  }
  return grid;
}

}  // namespace demnerf::geometry
