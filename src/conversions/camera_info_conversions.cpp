#include "conversions/camera_info_conversions.hpp"

#include "demnerf/core/error.hpp"

namespace dem_nerf {

sensor_msgs::CameraInfo toCameraInfo(const demnerf::core::PinholeCamera& camera, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(camera.width);
  info.height = static_cast<uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D = {camera.k1, camera.k2, camera.p1, camera.p2, 0.0};
  info.K = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  return info;
}

demnerf::core::PinholeCamera fromCameraInfo(const sensor_msgs::CameraInfo& info) {
  demnerf::core::PinholeCamera camera;
  camera.width = static_cast<int>(info.width);
  camera.height = static_cast<int>(info.height);
  camera.fx = info.K[0];
  camera.fy = info.K[4];
  camera.cx = info.K[2];
  camera.cy = info.K[5];
  if (!info.D.empty()) {
    if (info.distortion_model != "plumb_bob" && info.distortion_model != "rational_polynomial") {
      throw demnerf::core::Error("camera_info: distortion model '" + info.distortion_model +
                                 "' is not supported (use plumb_bob, or rectified images with D empty)");
    }
    if (info.D.size() < 4) throw demnerf::core::Error("camera_info: D must hold at least k1 k2 p1 p2");
    camera.k1 = info.D[0];
    camera.k2 = info.D[1];
    camera.p1 = info.D[2];
    camera.p2 = info.D[3];
    for (std::size_t i = 4; i < info.D.size(); ++i) {
      if (info.D[i] != 0.0) {
        throw demnerf::core::Error("camera_info: only k1 k2 p1 p2 distortion is modelled; D[" +
                                   std::to_string(i) + "] is not zero (rectify the images first)");
      }
    }
  }
  camera.validate();
  return camera;
}

}  // namespace dem_nerf
