#include "nodes/dem/deformed_view.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "demnerf/render/deformed_renderer.hpp"

namespace dem_nerf {

using demnerf::core::Error;

DeformedView::DeformedView() = default;
DeformedView::~DeformedView() = default;

void DeformedView::useModel(const std::string& path) {
  std::error_code code;
  const auto modified = std::filesystem::last_write_time(path, code);
  if (code) {
    model_.reset();
    path_.clear();
    throw Error("NeRF model file '" + path + "' cannot be read: " + code.message());
  }
  if (model_ && path == path_ && modified == modified_) return;
  model_.reset();
  path_.clear();
  model_ = std::make_unique<demnerf::nerf::NerfModel>(demnerf::nerf::loadModel(path));
  path_ = path;
  modified_ = modified;
}

cv::Mat DeformedView::render(const demnerf::core::ResultField& result, const demnerf::core::PinholeCamera& camera,
                             const Eigen::Isometry3d& world_from_camera) const {
  if (!model_) throw Error("no NeRF model loaded");
  camera.validate();
  if (!world_from_camera.matrix().allFinite()) throw Error("the render camera's pose holds NaN or Inf");
  const demnerf::render::DeformedScene scene(*model_, result);
  const demnerf::nerf::RenderedImage image = demnerf::render::renderDeformed(scene, camera, world_from_camera);
  return demnerf::nerf::toRgba(image);
}

demnerf::core::PinholeCamera cameraFromFieldOfView(int width, int height, double fov_degrees) {
  if (width <= 0 || height <= 0) {
    throw Error("render size must be positive, got " + std::to_string(width) + "x" + std::to_string(height));
  }
  if (!(fov_degrees > 0.0 && fov_degrees < 180.0)) {
    throw Error("render field of view must lie in (0, 180) degrees, got " + std::to_string(fov_degrees));
  }
  demnerf::core::PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = 0.5 * width / std::tan(0.5 * fov_degrees * M_PI / 180.0);
  camera.cx = 0.5 * width;
  camera.cy = 0.5 * height;
  return camera;
}

}  // namespace dem_nerf
