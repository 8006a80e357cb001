#pragma once
// Camera rays in the world frame, one per pixel.

#include <Eigen/Geometry>
#include <vector>

#include "demnerf/core/camera.hpp"

namespace demnerf::core {

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  ///< unit length, world frame
};

/// The ray through pixel position (u, v); world_from_camera is the optical frame's pose.
Ray generateRay(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                const Eigen::Vector2d& pixel);

/// Rays through every pixel centre, row-major (index = v * width + u).
std::vector<Ray> generatePixelRays(const PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera);

}  // namespace demnerf::core
