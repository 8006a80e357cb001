#include "demnerf/render/camera_rig.hpp"

#include <cmath>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::render {

std::vector<Eigen::Vector3d> fibonacciSphere(int count) {
  std::vector<Eigen::Vector3d> points;
  const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    points.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return points;
}

Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up) {
  const Eigen::Vector3d forward = (target - eye).normalized();
  Eigen::Vector3d right = forward.cross(up);
  if (right.norm() < 1e-3 * up.norm()) {
    // Looking straight along `up`: any perpendicular will do; pick one deterministically.
    right = forward.cross(std::abs(forward.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY());
  }
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = right;    // optical x: right
  pose.linear().col(1) = down;     // optical y: down
  pose.linear().col(2) = forward;  // optical z: forward
  pose.translation() = eye;
  return pose;
}

CameraRig makeCameraRig(const Eigen::AlignedBox3d& bounds, const CameraRigConfig& config) {
  if (config.train_views < 1) {
    throw core::Error("synthetic cameras: need at least one train view, got " + std::to_string(config.train_views));
  }
  if (config.test_views < 0) {
    throw core::Error("synthetic cameras: test views cannot be negative, got " + std::to_string(config.test_views));
  }
  if (config.width < 1 || config.height < 1) {
    throw core::Error("synthetic cameras: image size must be positive, got " + std::to_string(config.width) +
                      " x " + std::to_string(config.height));
  }
  if (!(config.fov_x_degrees > 0 && config.fov_x_degrees < 170)) {
    throw core::Error("synthetic cameras: field of view must be in (0, 170) degrees, got " +
                      std::to_string(config.fov_x_degrees));
  }
  if (bounds.isEmpty()) throw core::Error("synthetic cameras: the object's bounds are empty");
  CameraRig rig;
  auto& camera = rig.camera;
  camera.width = config.width;
  camera.height = config.height;
  const double half_fov = 0.5 * config.fov_x_degrees * M_PI / 180.0;
  camera.fx = 0.5 * config.width / std::tan(half_fov);
  camera.fy = camera.fx;
  camera.cx = 0.5 * config.width;
  camera.cy = 0.5 * config.height;
  // The bounding sphere fits the narrower of the two fields of view.
  const double half_fov_y = std::atan(0.5 * config.height / camera.fy);
  const double radius = 0.5 * bounds.diagonal().norm();
  rig.distance = config.margin * radius / std::sin(std::min(half_fov, half_fov_y));
  const Eigen::Vector3d centre = bounds.center();
  const int total = config.train_views + config.test_views;
  const auto directions = fibonacciSphere(total);
  // Test view j takes direction floor((j + 0.5) * total / test_views): evenly spread in height.
  std::vector<bool> is_test(total, false);
  for (int j = 0; j < config.test_views; ++j) {
    is_test[static_cast<int>((j + 0.5) * total / config.test_views)] = true;
  }
  for (int i = 0; i < total; ++i) {
    const Eigen::Isometry3d pose = lookAt(centre + rig.distance * directions[i], centre, config.up);
    (is_test[i] ? rig.test : rig.train).push_back(pose);
  }
  return rig;
}

}  // namespace demnerf::render
