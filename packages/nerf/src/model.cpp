#include "demnerf/nerf/model.hpp"

#include "demnerf/core/error.hpp"

namespace demnerf::nerf {

NerfModel::NerfModel(const NerfConfig& config, const Box& bounds, double aabb_scale)
    : ngp_(config, bounds, aabb_scale, config.train.seed),
      march_(MarchParams::make(config.march, bounds, aabb_scale, config.occupancy.resolution)),
      render_march_(MarchParams::makeRender(config.march, bounds, aabb_scale, config.occupancy.resolution)) {
  grid_ = OccupancyGrid(config.occupancy, bounds, march_.min_step, cascadeCount(config.occupancy, aabb_scale));
}

std::vector<float> NerfModel::densityGrid(int resolution) const {
  if (resolution < 2 || resolution > 2048) {
    throw core::Error("density grid resolution must be in [2, 2048], got " + std::to_string(resolution));
  }
  const std::int64_t n = static_cast<std::int64_t>(resolution) * resolution * resolution;
  std::vector<float> sigma(n);
  const Box box = bounds();
  // One z slice at a time keeps the point buffer small for large resolutions.
  std::vector<float> points(3 * static_cast<std::size_t>(resolution) * resolution);
  for (int z = 0; z < resolution; ++z) {
    std::size_t k = 0;
    for (int y = 0; y < resolution; ++y) {
      for (int x = 0; x < resolution; ++x) {
        const int idx[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) points[k++] = box.min[a] + (idx[a] + 0.5f) / resolution * box.size(a);
      }
    }
    field().density(points.data(), static_cast<std::int64_t>(resolution) * resolution,
                   sigma.data() + static_cast<std::int64_t>(z) * resolution * resolution);
  }
  return sigma;
}

}  // namespace demnerf::nerf
