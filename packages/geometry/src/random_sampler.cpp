#include <cmath>

#include "demnerf/core/error.hpp"
#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

SampleSet sampleRandom(const PreparedMesh& prepared, const SamplerConfig& config, Rng& rng) {
  // The paper's Eq. (randomSample): x = x_min + U(0, 1) (x_max - x_min), kept when inside.
  // As many particles as grid cells of size h fit in the body, for a comparable density.
  const double h = config.spacing;
  const auto count = static_cast<std::size_t>(std::max(1.0, std::round(prepared.volume() / (h * h * h))));
  const Eigen::Vector3d lo = prepared.bounds().min();
  const Eigen::Vector3d extent = prepared.bounds().max() - lo;
  const double fill = prepared.volume() / extent.prod();
  const std::size_t max_draws = static_cast<std::size_t>(20.0 * count / std::max(fill, 1e-6)) + 10000;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  SampleSet set;
  set.interior.reserve(count);
  std::size_t draws = 0;
  while (set.interior.size() < count && draws < max_draws) {
    ++draws;
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) p[a] = lo[a] + uniform(rng) * extent[a];
    if (prepared.inside.inside(p)) set.interior.push_back(p);
  }
  if (set.interior.size() < count) {
    throw core::Error("random sampler: only " + std::to_string(set.interior.size()) + " of " + std::to_string(count) +
                      " points drawn in the bounding box fell inside the mesh; is it a solid body?");
  }
  if (config.surface) {
    const auto surface_count = static_cast<std::size_t>(std::max(1.0, std::round(prepared.area() / (h * h))));
    sampleSurfaceRandom(prepared, surface_count, rng, &set);
  }
  return set;
}

}  // namespace demnerf::geometry::detail
