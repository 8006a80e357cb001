#pragma once
// Replays a transforms.json dataset as a camera rig would publish it: Image + CameraInfo on
// <camera>/image_raw and <camera>/camera_info, and every frame's optical pose on /tf_static.

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <memory>
#include <string>
#include <vector>

#include "conversions/dataset_messages.hpp"

namespace dem_nerf {

struct DatasetPlayerConfig {
  std::string data;              ///< dataset folder (required)
  std::string split = "train";   ///< train | test | all
  double rate = 5.0;             ///< images per second
  bool loop = true;              ///< start again after the last frame
  double downscale = 1.0;        ///< 2 halves the images
  std::string camera = "camera"; ///< topic namespace of the published camera
  FrameNaming naming;

  /// Reads ~ parameters; throws demnerf::core::Error naming a bad value.
  static DatasetPlayerConfig fromParameters(const ros::NodeHandle& private_node);
};

class DatasetPlayer {
 public:
  DatasetPlayer(ros::NodeHandle node, const DatasetPlayerConfig& config);

 private:
  void publishNext(const ros::TimerEvent&);

  DatasetPlayerConfig config_;
  std::vector<demnerf::core::Frame> frames_;
  image_transport::ImageTransport transport_;
  image_transport::CameraPublisher publisher_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  ros::Timer timer_;
  std::size_t next_ = 0;
};

}  // namespace dem_nerf
