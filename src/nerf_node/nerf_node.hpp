#pragma once
// nerf_node: collects posed keyframes from the rig's cameras and trains the NeRF on them.
// All algorithms live in packages/; this class only wires them to ROS.

#include <dem_nerf/ExtractParticles.h>
#include <dem_nerf/LoadModel.h>
#include <dem_nerf/RenderView.h>
#include <dem_nerf/SaveModel.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <mutex>
#include <string>
#include <vector>

#include "nerf_node/frame_intake.hpp"
#include "nerf_node/nerf_node_config.hpp"

namespace dem_nerf {

class NerfNode {
 public:
  NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config);

 private:
  void onImage(const std::string& camera, const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& info);
  void pollFrames(const ros::TimerEvent&);
  void publishStatus(const ros::TimerEvent&);
  void reportError(const std::string& message);
  void fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);

  bool render(dem_nerf::RenderView::Request&, dem_nerf::RenderView::Response& response);
  bool extract(dem_nerf::ExtractParticles::Request&, dem_nerf::ExtractParticles::Response& response);
  bool save(dem_nerf::SaveModel::Request&, dem_nerf::SaveModel::Response& response);
  bool load(dem_nerf::LoadModel::Request&, dem_nerf::LoadModel::Response& response);
  bool reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response);

  NerfNodeConfig config_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  FrameIntake intake_;
  image_transport::ImageTransport transport_;
  std::vector<image_transport::CameraSubscriber> camera_subscribers_;
  ros::Publisher status_publisher_, particles_publisher_, mesh_publisher_, model_publisher_;
  image_transport::Publisher preview_publisher_;
  std::vector<ros::ServiceServer> services_;
  ros::Timer status_timer_, poll_timer_;
  diagnostic_updater::Updater diagnostics_;

  std::mutex mutex_;  // guards everything below
  std::vector<demnerf::core::Frame> keyframes_;
  std::string last_error_;
};

}  // namespace dem_nerf
