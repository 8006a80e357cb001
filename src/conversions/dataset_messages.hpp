#pragma once
// One dataset frame as the messages a camera rig would send: Image, CameraInfo and the tf of
// its optical frame. Shared by dataset_player (live) and `demnerf bag` (to a rosbag).

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <string>

#include "demnerf/core/dataset.hpp"

namespace dem_nerf {

struct FrameMessages {
  sensor_msgs::Image image;             ///< rgba8 when the dataset has alpha, else rgb8
  sensor_msgs::CameraInfo camera_info;
  geometry_msgs::TransformStamped pose; ///< world_frame -> the frame's optical frame
};

struct FrameNaming {
  std::string world_frame = "world";
  std::string frame_prefix = "dataset_camera_";  ///< optical frames are <prefix><index>_optical
};

std::string opticalFrameName(const FrameNaming& naming, std::size_t index);

FrameMessages toMessages(const demnerf::core::Frame& frame, std::size_t index, const ros::Time& stamp,
                         const FrameNaming& naming);

}  // namespace dem_nerf
