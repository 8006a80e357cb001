#pragma once
// Pinhole camera with Brown-Conrady (k1 k2 p1 p2) distortion, in the REP-103 optical frame.

#include <Eigen/Core>

namespace demnerf::core {

/// Intrinsics of one camera. Pixel (u, v) = (0, 0) is the top-left corner of the top-left
/// pixel, so the centre of pixel (i, j) is (i + 0.5, j + 0.5).
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;

  bool hasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0; }

  /// Projects a point in the optical frame (z forward) to a pixel. Requires z > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& point_in_camera) const;

  /// Unit-length viewing direction (optical frame) of the ray through a pixel position.
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;

  /// The same camera seen at 1/factor of the resolution (factor 2 halves width and height).
  PinholeCamera downscaled(double factor) const;

  /// Throws core::Error naming the bad field when the intrinsics are unusable.
  void validate() const;

  /// Applies the distortion model to normalised coordinates (x/z, y/z).
  Eigen::Vector2d distort(const Eigen::Vector2d& normalized) const;
  /// Inverts distort() by fixed-point iteration (converges for realistic lenses).
  Eigen::Vector2d undistort(const Eigen::Vector2d& distorted) const;
};

}  // namespace demnerf::core
