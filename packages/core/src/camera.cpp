#include "demnerf/core/camera.hpp"

#include <Eigen/LU>

#include <cmath>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::core {

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& normalized) const {
  const double x = normalized.x(), y = normalized.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& distorted) const {
  if (!hasDistortion()) return distorted;
  // Newton iterations on distort(x) = distorted with a numeric Jacobian: converges in a few
  // steps for the mild lenses of COLMAP/instant-ngp datasets, and stays well-behaved near the
  // image corners where plain fixed-point iteration can oscillate.
  Eigen::Vector2d x = distorted;
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::Vector2d residual = distort(x) - distorted;
    if (residual.squaredNorm() < 1e-24) break;
    const double h = 1e-7;
    Eigen::Matrix2d jacobian;
    jacobian.col(0) = (distort(x + Eigen::Vector2d(h, 0)) - distort(x)) / h;
    jacobian.col(1) = (distort(x + Eigen::Vector2d(0, h)) - distort(x)) / h;
    x -= jacobian.partialPivLu().solve(residual);
  }
  return x;
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& point_in_camera) const {
  const Eigen::Vector2d normalized = point_in_camera.head<2>() / point_in_camera.z();
  const Eigen::Vector2d d = distort(normalized);
  return {fx * d.x() + cx, fy * d.y() + cy};
}

Eigen::Vector3d PinholeCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d distorted((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  const Eigen::Vector2d normalized = undistort(distorted);
  return Eigen::Vector3d(normalized.x(), normalized.y(), 1.0).normalized();
}

PinholeCamera PinholeCamera::downscaled(double factor) const {
  if (!(factor > 0.0) || !std::isfinite(factor)) {
    throw Error("downscale factor must be a positive number, got " + std::to_string(factor));
  }
  PinholeCamera scaled = *this;
  scaled.width = static_cast<int>(std::lround(width / factor));
  scaled.height = static_cast<int>(std::lround(height / factor));
  // Scale by the ratio actually achieved so that pixel edges keep lining up after rounding.
  const double sx = static_cast<double>(scaled.width) / width;
  const double sy = static_cast<double>(scaled.height) / height;
  scaled.fx *= sx;
  scaled.cx *= sx;
  scaled.fy *= sy;
  scaled.cy *= sy;
  return scaled;
}

void PinholeCamera::validate() const {
  auto fail = [](const std::string& what) { throw Error("camera intrinsics: " + what); };
  if (width <= 0 || height <= 0) {
    fail("image size must be positive, got " + std::to_string(width) + "x" + std::to_string(height));
  }
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    fail("focal lengths must be positive and finite, got fx=" + std::to_string(fx) +
         " fy=" + std::to_string(fy));
  }
  for (double value : {cx, cy, k1, k2, p1, p2}) {
    if (!std::isfinite(value)) fail("principal point and distortion must be finite");
  }
}

}  // namespace demnerf::core
