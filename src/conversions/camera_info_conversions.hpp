#pragma once
// sensor_msgs/CameraInfo <-> core::PinholeCamera (plumb_bob distortion: k1 k2 p1 p2 k3=0).

#include <sensor_msgs/CameraInfo.h>

#include "demnerf/core/camera.hpp"

namespace dem_nerf {

sensor_msgs::CameraInfo toCameraInfo(const demnerf::core::PinholeCamera& camera, const std_msgs::Header& header);

/// Throws demnerf::core::Error for a CameraInfo that cannot be used (zero size or focal length,
/// an unsupported distortion model, a k3 we do not model).
demnerf::core::PinholeCamera fromCameraInfo(const sensor_msgs::CameraInfo& info);

}  // namespace dem_nerf
