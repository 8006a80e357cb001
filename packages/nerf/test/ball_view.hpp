#pragma once
// What the nerf tests that need a known body train on: an opaque ball at the origin,
// coloured by its normal, on a transparent background (test_density_prior.cpp, test_distortion.cpp),
// and the small field they and test_training.cpp train.

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/core.hpp>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/config.hpp"

namespace demnerf::nerf::test {

constexpr double kBallRadius = 0.4;

/// A camera at `eye` looking at the origin (optical frame), size x size pixels, and what it sees.
inline core::Frame ballViewFrom(const Eigen::Vector3d& eye, int size) {
  core::Frame frame;
  frame.camera.width = frame.camera.height = size;
  frame.camera.fx = frame.camera.fy = size * 1.1;
  frame.camera.cx = frame.camera.cy = size / 2.0;
  const Eigen::Vector3d z = (-eye).normalized();
  const Eigen::Vector3d up = std::fabs(z.z()) > 0.95 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = z.cross(up).normalized();
  frame.world_from_camera.linear() << x, z.cross(x), z;
  frame.world_from_camera.translation() = eye;
  frame.rgba.create(size, size, CV_32FC4);
  frame.has_alpha = true;
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      const Eigen::Vector3d d = (frame.world_from_camera.linear() *
                                 Eigen::Vector3d((u + 0.5 - size / 2.0) / frame.camera.fx,
                                                 (v + 0.5 - size / 2.0) / frame.camera.fy, 1.0)).normalized();
      const double b = eye.dot(d), disc = b * b - (eye.squaredNorm() - kBallRadius * kBallRadius);
      cv::Vec4f pixel(0, 0, 0, 0);
      if (disc > 0) {
        const Eigen::Vector3f n = (eye + (-b - std::sqrt(disc)) * d).normalized().cast<float>();
        pixel = cv::Vec4f(0.5f + 0.4f * n.x(), 0.5f + 0.4f * n.y(), 0.5f + 0.4f * n.z(), 1.0f);
      }
      frame.rgba.at<cv::Vec4f>(v, u) = pixel;
    }
  return frame;
}

/// A field small enough to learn the ball in a test's seconds.
inline NerfConfig smallBallConfig() {
  NerfConfig c;
  c.hash.levels = 8;
  c.hash.log2_table_size = 14;
  c.hash.finest_resolution = 128;
  c.occupancy.resolution = 32;
  c.train.target_samples = 1 << 13;
  return c;
}

}  // namespace demnerf::nerf::test
