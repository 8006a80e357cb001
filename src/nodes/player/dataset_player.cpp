#include "nodes/player/dataset_player.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

DatasetPlayerConfig DatasetPlayerConfig::fromParameters(const ros::NodeHandle& private_node) {
  DatasetPlayerConfig config;
  if (!private_node.getParam("data", config.data) || config.data.empty()) {
    throw demnerf::core::Error("parameter ~data is required: the dataset folder holding transforms.json");
  }
  private_node.param("split", config.split, config.split);
  private_node.param("rate", config.rate, config.rate);
  private_node.param("loop", config.loop, config.loop);
  private_node.param("downscale", config.downscale, config.downscale);
  private_node.param("camera", config.camera, config.camera);
  private_node.param("world_frame", config.naming.world_frame, config.naming.world_frame);
  private_node.param("frame_prefix", config.naming.frame_prefix, config.naming.frame_prefix);
  if (!(config.rate > 0) || !std::isfinite(config.rate)) {
    throw demnerf::core::Error("parameter ~rate must be a positive number of images per second");
  }
  if (config.split != "train" && config.split != "test" && config.split != "all") {
    throw demnerf::core::Error("parameter ~split must be train, test or all, got '" + config.split + "'");
  }
  return config;
}

DatasetPlayer::DatasetPlayer(ros::NodeHandle node, const DatasetPlayerConfig& config)
    : config_(config), transport_(node) {
  demnerf::core::DatasetOptions options;
  options.downscale = config.downscale;
  const demnerf::core::Dataset dataset = demnerf::core::loadDataset(config.data, options);
  frames_ = dataset.frames(config.split);
  if (frames_.empty()) throw demnerf::core::Error("dataset '" + config.data + "' has no " + config.split + " frames");
  if (!dataset.missing_images.empty()) {
    ROS_WARN("dataset_player: %zu frames of '%s' have no image file and are skipped (first: %s)",
             dataset.missing_images.size(), config.data.c_str(), dataset.missing_images.front().c_str());
  }

  // Every frame is a fixed camera pose, so all of them go out once on /tf_static: valid at any
  // stamp, and a late subscriber still receives them (latched).
  std::vector<geometry_msgs::TransformStamped> poses;
  const ros::Time now = ros::Time::now();
  for (std::size_t i = 0; i < frames_.size(); ++i) {
    poses.push_back(toMessages(frames_[i], i, now, config.naming).pose);
  }
  static_broadcaster_.sendTransform(poses);

  publisher_ = transport_.advertiseCamera(config.camera + "/image_raw", 1);
  timer_ = node.createTimer(ros::Duration(1.0 / config.rate), &DatasetPlayer::publishNext, this);
  ROS_INFO("dataset_player: %zu %s frames of '%s' at %.1f Hz on %s/image_raw%s", frames_.size(),
           config.split.c_str(), config.data.c_str(), config.rate, config.camera.c_str(),
           config.loop ? ", looping" : ", once");
}

void DatasetPlayer::publishNext(const ros::TimerEvent&) {
  if (next_ == frames_.size()) {
    if (!config_.loop) {
      timer_.stop();
      ROS_INFO("dataset_player: all %zu frames published", frames_.size());
      return;
    }
    next_ = 0;
  }
  const FrameMessages messages = toMessages(frames_[next_], next_, ros::Time::now(), config_.naming);
  publisher_.publish(messages.image, messages.camera_info);
  ++next_;
}

}  // namespace dem_nerf
