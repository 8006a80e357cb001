#include "demnerf/core/ray.hpp"

namespace demnerf::core {

Ray generateRay(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                const Eigen::Vector2d& pixel) {
  return {world_from_camera.translation(), world_from_camera.linear() * camera.unproject(pixel)};
}

std::vector<Ray> generatePixelRays(const PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera) {
  std::vector<Ray> rays;
  rays.reserve(static_cast<std::size_t>(camera.width) * camera.height);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      rays.push_back(generateRay(camera, world_from_camera, {u + 0.5, v + 0.5}));
    }
  }
  return rays;
}

}  // namespace demnerf::core
