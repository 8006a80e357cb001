#pragma once
// Cameras spread evenly on a sphere around an object, all looking at its centre.

#include <Eigen/Geometry>
#include <vector>

#include "demnerf/core/camera.hpp"

namespace demnerf::render {

struct CameraRigConfig {
  int train_views = 48;
  int test_views = 8;
  int width = 200;
  int height = 200;
  double fov_x_degrees = 40.0;  ///< horizontal field of view
  double margin = 1.02;         ///< distance factor beyond the one that just fits the bounding sphere
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< world up: image rows run against it
};

struct CameraRig {
  core::PinholeCamera camera;                       ///< shared intrinsics
  std::vector<Eigen::Isometry3d> train;             ///< world_from_camera, optical frame
  std::vector<Eigen::Isometry3d> test;
  double distance = 0.0;                            ///< from the centre, m
};

/// `count` unit directions of a Fibonacci sphere (z from near +1 to near -1, golden-angle steps).
std::vector<Eigen::Vector3d> fibonacciSphere(int count);

/// Optical-frame pose of a camera at `eye` looking at `target` with image up along `up`
/// (falls back to another up when the view is nearly parallel to it).
Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up);

/// One Fibonacci sphere of train + test directions; the test views are every k-th direction,
/// spread over all heights, so they never coincide with a train view. Throws core::Error on a
/// non-positive view count or image size.
CameraRig makeCameraRig(const Eigen::AlignedBox3d& bounds, const CameraRigConfig& config);

}  // namespace demnerf::render
