#include "nerf_node/nerf_node.hpp"

#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/Marker.h>

#include "conversions/camera_info_conversions.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

const char* kNotBuilt = "the NeRF training stage is not built yet in this version of dem_nerf";

std::string describe(const FrameIntakeCounts& counts) {
  return std::to_string(counts.received) + " images: " + std::to_string(counts.keyframes) + " keyframes, " +
         std::to_string(counts.not_new) + " too close to a keyframe, " + std::to_string(counts.rejected) +
         " rejected, " + std::to_string(counts.tf_missing) + " without tf, " + std::to_string(counts.tf_too_slow) +
         " with tf too slow";
}

}  // namespace

FrameIntakeConfig intakeConfig(const NerfNodeConfig& config) {
  FrameIntakeConfig intake;
  intake.world_frame = config.world_frame;
  intake.tf_timeout = config.tf_timeout;
  intake.max_image_size = config.max_image_size;
  intake.keyframes.min_translation = config.min_translation;
  intake.keyframes.min_rotation_degrees = config.min_rotation;
  intake.keyframes.max_frames = static_cast<std::size_t>(config.max_frames);
  if (!config.background_color.empty()) {
    demnerf::core::ColourKey key;
    key.color = cv::Vec3f(config.background_color[0], config.background_color[1], config.background_color[2]);
    key.tolerance = config.key_tolerance;
    intake.colour_key = key;
  }
  return intake;
}

NerfNode::NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config)
    : config_(config), tf_listener_(tf_buffer_), intake_(intakeConfig(config), tf_buffer_), transport_(node) {
  for (const std::string& camera : config_.cameras) {
    camera_subscribers_.push_back(transport_.subscribeCamera(
        camera + "/image_raw", 2,
        [this, camera](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) {
          onImage(camera, image, info);
        }));
  }
  status_publisher_ = private_node.advertise<dem_nerf::TrainingStatus>("status", 10);
  image_transport::ImageTransport private_transport(private_node);
  preview_publisher_ = private_transport.advertise("preview", 1);
  particles_publisher_ = private_node.advertise<sensor_msgs::PointCloud2>("particles", 1, true);
  mesh_publisher_ = private_node.advertise<visualization_msgs::Marker>("mesh", 1, true);
  model_publisher_ = private_node.advertise<dem_nerf::ModelInfo>("model", 1, true);
  services_.push_back(private_node.advertiseService("render", &NerfNode::render, this));
  services_.push_back(private_node.advertiseService("extract", &NerfNode::extract, this));
  services_.push_back(private_node.advertiseService("save", &NerfNode::save, this));
  services_.push_back(private_node.advertiseService("load", &NerfNode::load, this));
  services_.push_back(private_node.advertiseService("reset", &NerfNode::reset, this));
  status_timer_ = private_node.createTimer(ros::Duration(1.0), &NerfNode::publishStatus, this);
  poll_timer_ = private_node.createTimer(ros::Duration(0.05), &NerfNode::pollFrames, this);
  diagnostics_.setHardwareID("dem_nerf");
  diagnostics_.add("nerf_node", this, &NerfNode::fillDiagnostics);
  ROS_INFO("nerf_node: listening to %zu camera(s); %s", config_.cameras.size(), kNotBuilt);
}

void NerfNode::onImage(const std::string& camera, const sensor_msgs::ImageConstPtr& image,
                       const sensor_msgs::CameraInfoConstPtr& info) {
  try {
    intake_.add(*image, *info);
  } catch (const demnerf::core::Error& error) {
    reportError(camera + ": " + error.what());
  }
}

void NerfNode::pollFrames(const ros::TimerEvent&) {
  std::vector<std::string> dropped;
  std::vector<demnerf::core::Frame> fresh = intake_.poll(&dropped);
  for (const std::string& reason : dropped) reportError(reason);
  if (fresh.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& frame : fresh) keyframes_.push_back(std::move(frame));
  // The frame store is bounded: the oldest keyframes make room (the selector forgets them too).
  while (keyframes_.size() > static_cast<std::size_t>(config_.max_frames)) keyframes_.erase(keyframes_.begin());
}

void NerfNode::reportError(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = message;
  }
  ROS_WARN_THROTTLE(5.0, "nerf_node: %s", message.c_str());
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.stage = "error";
  status.message = message;
  status_publisher_.publish(status);
}

void NerfNode::publishStatus(const ros::TimerEvent&) {
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.header.frame_id = config_.world_frame;
  const FrameIntakeCounts counts = intake_.counts();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status.stage = "waiting_for_frames";
    status.frames = static_cast<uint32_t>(keyframes_.size());
    status.message = describe(counts) + (last_error_.empty() ? "" : " (last error: " + last_error_ + ")") + "; " +
                     kNotBuilt;
  }
  status_publisher_.publish(status);
  diagnostics_.update();  // takes mutex_ itself, in fillDiagnostics
}

void NerfNode::fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status.summary(last_error_.empty() ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN,
                 last_error_.empty() ? "waiting for frames" : last_error_);
  const FrameIntakeCounts counts = intake_.counts();
  status.add("images received", counts.received);
  status.add("keyframes", counts.keyframes);
  status.add("rejected", counts.rejected);
  status.add("tf missing", counts.tf_missing);
  status.add("tf too slow", counts.tf_too_slow);
}

bool NerfNode::render(dem_nerf::RenderView::Request&, dem_nerf::RenderView::Response& response) {
  response.ok = false;
  response.message = kNotBuilt;
  return true;
}

bool NerfNode::extract(dem_nerf::ExtractParticles::Request&, dem_nerf::ExtractParticles::Response& response) {
  response.ok = false;
  response.message = kNotBuilt;
  return true;
}

bool NerfNode::save(dem_nerf::SaveModel::Request&, dem_nerf::SaveModel::Response& response) {
  response.ok = false;
  response.message = std::string("nothing to save: ") + kNotBuilt;
  return true;
}

bool NerfNode::load(dem_nerf::LoadModel::Request&, dem_nerf::LoadModel::Response& response) {
  response.ok = false;
  response.message = kNotBuilt;
  return true;
}

bool NerfNode::reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  intake_.reset();
  std::lock_guard<std::mutex> lock(mutex_);
  keyframes_.clear();
  last_error_.clear();
  response.success = true;
  response.message = "keyframes and counters cleared";
  return true;
}

}  // namespace dem_nerf
