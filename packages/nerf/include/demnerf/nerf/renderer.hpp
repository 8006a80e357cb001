#pragma once
// Full images of a NeRF from any pinhole camera: colour, expected depth and opacity.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "demnerf/core/camera.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/nerf/ray_batch.hpp"

namespace demnerf::nerf {

struct RenderedImage {
  cv::Mat color;    ///< CV_32FC3 RGB in [0, 1], composited over the background
  cv::Mat depth;    ///< CV_32FC1, distance along the ray (m) weighted by opacity
  cv::Mat opacity;  ///< CV_32FC1 in [0, 1]
  double seconds = 0;
  std::int64_t samples = 0;
};

/// Colour and opacity as one CV_32FC4 RGBA image (for PNG files and image messages).
cv::Mat toRgba(const RenderedImage& image);

/// A view of any field (the NeRF, a deformed body) through the one marching + compositing
/// path, renderRays. world_from_camera is the optical frame (z forward, y down);
/// background: RGB in [0, 1].
RenderedImage renderView(const Field& field, const MarchScene& scene, const core::PinholeCamera& camera,
                         const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background);

/// world_from_camera is the optical frame (z forward, y down). background: RGB in [0, 1].
RenderedImage renderImage(const NerfModel& model, const core::PinholeCamera& camera,
                          const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background);

/// The same with the model's configured background.
RenderedImage renderImage(const NerfModel& model, const core::PinholeCamera& camera,
                          const Eigen::Isometry3d& world_from_camera);

}  // namespace demnerf::nerf
