#include "nerf_node/nerf_node.hpp"

#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <visualization_msgs/Marker.h>

#include "conversions/camera_info_conversions.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

namespace encodings = sensor_msgs::image_encodings;

const char* kNotBuilt = "the NeRF training stage is not built yet in this version of dem_nerf";

// Throws core::Error when the image cannot be used as a training view.
void validateImage(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info) {
  const std::string& e = image.encoding;
  if (e != encodings::RGB8 && e != encodings::BGR8 && e != encodings::RGBA8 && e != encodings::BGRA8 &&
      e != encodings::MONO8) {
    throw demnerf::core::Error("image encoding '" + e + "' is not supported (use rgb8, bgr8, rgba8, bgra8 or mono8)");
  }
  if (image.width != info.width || image.height != info.height) {
    throw demnerf::core::Error("image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                               " but its camera_info says " + std::to_string(info.width) + "x" +
                               std::to_string(info.height));
  }
  fromCameraInfo(info);  // checks intrinsics and distortion model
}

}  // namespace

NerfNode::NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config)
    : config_(config), transport_(node) {
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
  diagnostics_.setHardwareID("dem_nerf");
  diagnostics_.add("nerf_node", this, &NerfNode::fillDiagnostics);
  ROS_INFO("nerf_node: listening to %zu camera(s); %s", config_.cameras.size(), kNotBuilt);
}

void NerfNode::onImage(const std::string& camera, const sensor_msgs::ImageConstPtr& image,
                       const sensor_msgs::CameraInfoConstPtr& info) {
  try {
    validateImage(*image, *info);
    std::lock_guard<std::mutex> lock(mutex_);
    ++images_accepted_;
  } catch (const demnerf::core::Error& error) {
    reportError(camera + ": " + error.what());
  }
}

void NerfNode::reportError(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++images_rejected_;
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
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status.stage = "waiting_for_frames";
    status.frames = 0;
    status.message = std::to_string(images_accepted_) + " images received, " + std::to_string(images_rejected_) +
                     " rejected" + (last_error_.empty() ? "" : " (last: " + last_error_ + ")") + "; " + kNotBuilt;
  }
  status_publisher_.publish(status);
  diagnostics_.update();  // takes mutex_ itself, in fillDiagnostics
}

void NerfNode::fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status.summary(last_error_.empty() ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN,
                 last_error_.empty() ? "waiting for frames" : last_error_);
  status.add("images accepted", images_accepted_);
  status.add("images rejected", images_rejected_);
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
  std::lock_guard<std::mutex> lock(mutex_);
  images_accepted_ = images_rejected_ = 0;
  last_error_.clear();
  response.success = true;
  response.message = "frame counters cleared";
  return true;
}

}  // namespace dem_nerf
