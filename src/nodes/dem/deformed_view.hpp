#pragma once
// What dem_node's ~rendered needs from the render library: the NeRF model file kept loaded
// (reloaded when its path or modification time changes, as nerf_node rewrites it in place) and
// a simulation result turned into an RGBA8 image through render::DeformedScene. Kept apart from
// dem_node.cpp so the node's translation unit does not pull in the NeRF's torch headers.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <string>

#include "demnerf/core/camera.hpp"
#include "demnerf/core/ply.hpp"

namespace demnerf::nerf {
class NerfModel;
}

namespace dem_nerf {

class DeformedView {
 public:
  DeformedView();
  ~DeformedView();
  DeformedView(const DeformedView&) = delete;
  DeformedView& operator=(const DeformedView&) = delete;

  /// Loads the model file unless the same file (path and modification time) is loaded already.
  /// Throws demnerf::core::Error naming the file when it is missing, corrupt or of another
  /// version; the model loaded before, if any, is dropped so a stale one is never rendered.
  void useModel(const std::string& path);

  /// RGBA float image (CV_32FC4, [0, 1]) of the result's deformed body seen from world_from_camera (optical
  /// frame, in the model's world frame). Throws demnerf::core::Error when no model is loaded or
  /// the result does not fit it (another body, empty, NaN).
  cv::Mat render(const demnerf::core::ResultField& result, const demnerf::core::PinholeCamera& camera,
                 const Eigen::Isometry3d& world_from_camera) const;

 private:
  std::unique_ptr<demnerf::nerf::NerfModel> model_;
  std::string path_;
  std::filesystem::file_time_type modified_{};
};

/// A distortion-free camera of the given size whose horizontal field of view is fov_degrees.
demnerf::core::PinholeCamera cameraFromFieldOfView(int width, int height, double fov_degrees);

}  // namespace dem_nerf
