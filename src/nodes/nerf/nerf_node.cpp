#include "nodes/nerf/nerf_node.hpp"

#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/Marker.h>

#include <filesystem>

#include "conversions/image_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"

namespace dem_nerf {
namespace {

std::string describe(const FrameIntakeCounts& counts) {
  return std::to_string(counts.received) + " images: " + std::to_string(counts.keyframes) + " keyframes, " +
         std::to_string(counts.not_new) + " too close to a keyframe, " + std::to_string(counts.rejected) +
         " rejected, " + std::to_string(counts.tf_missing) + " without tf, " + std::to_string(counts.tf_too_slow) +
         " with tf too slow";
}

}  // namespace

NerfNode::NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config)
    : config_(config),
      nerf_config_(config.nerf),
      tf_listener_(tf_buffer_),
      intake_(config.intake(), tf_buffer_),
      transport_(node) {
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
  ros::NodeHandle service_node(private_node);
  service_node.setCallbackQueue(&service_queue_);
  services_.push_back(service_node.advertiseService("render", &NerfNode::render, this));
  services_.push_back(service_node.advertiseService("extract", &NerfNode::extract, this));
  services_.push_back(service_node.advertiseService("save", &NerfNode::save, this));
  services_.push_back(service_node.advertiseService("load", &NerfNode::load, this));
  services_.push_back(service_node.advertiseService("reset", &NerfNode::reset, this));
  diagnostics_.setHardwareID("dem_nerf");
  diagnostics_.add("nerf_node", this, &NerfNode::fillDiagnostics);

  // Resume: a model saved by an earlier run is where training continues once frames arrive.
  if (std::filesystem::exists(config_.model_path)) {
    try {
      resume_from_ = std::make_unique<demnerf::nerf::NerfModel>(demnerf::nerf::loadModel(config_.model_path));
      trained_ = std::make_shared<const demnerf::nerf::NerfModel>(*resume_from_);
      stage_ = "waiting_for_frames";
    } catch (const std::exception& error) {
      reportError("resume", std::string("not resuming: ") + error.what());
    }
  }
  if (resume_from_) {
    try {
      const std::optional<demnerf::nerf::TrainingRecord> record = demnerf::nerf::readTrainingRecord(config_.model_path);
      resumed_ = record.value_or(demnerf::nerf::TrainingRecord{});
      resume_note_ = record ? "resumed from iteration " + std::to_string(resumed_.iteration) + " (" +
                                  std::to_string(static_cast<int>(resumed_.seconds)) + " s of training) of '" +
                                  config_.model_path + "'"
                            : "resumed the weights of '" + config_.model_path +
                                  "' (no training record in its header: the iteration count starts at 0)";
    } catch (const demnerf::core::Error& error) {
      resume_note_ = "resumed the weights of '" + config_.model_path + "'; iteration count starts at 0";
      reportError("resume", error.what());
    }
    ROS_INFO("nerf_node: %s", resume_note_.c_str());
  }
  status_timer_ = private_node.createTimer(ros::Duration(1.0), &NerfNode::publishStatus, this);
  poll_timer_ = private_node.createTimer(ros::Duration(0.05), &NerfNode::pollFrames, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();
  ROS_INFO("nerf_node: listening to %zu camera(s); training starts at %d keyframes; model file '%s'",
           config_.cameras.size(), config_.min_frames, config_.model_path.c_str());
}

NerfNode::~NerfNode() {
  if (service_spinner_) service_spinner_->stop();  // waits for a service call in progress
  for (ros::ServiceServer& service : services_) service.shutdown();  // before their queue goes
  service_queue_.disable();
  service_queue_.clear();
  std::unique_ptr<demnerf::nerf::BackgroundTrainer> background;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    background = std::move(background_);
  }
  background.reset();  // joins the thread after its final save
}

void NerfNode::onImage(const std::string& camera, const sensor_msgs::ImageConstPtr& image,
                       const sensor_msgs::CameraInfoConstPtr& info) {
  // Images the subscriber queue dropped in a burst, or whose camera_info never matched, leave a
  // gap in the publisher's sequence numbers: counted, so no drop goes unseen.
  std::uint32_t missed = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::uint32_t& last = last_sequence_[camera];
    if (last != 0 && image->header.seq > last + 1) missed = image->header.seq - last - 1;
    last = image->header.seq;
  }
  if (missed > 0)
    rejections_.count("image_not_received", camera + ": " + std::to_string(missed) +
                                                " image(s) dropped before the node saw them (subscriber queue full, "
                                                "or no camera_info with the same stamp)");
  try {
    intake_.add(*image, *info);
  } catch (const std::exception& error) {  // core::Error from the checks; anything else too
    reportError("image", camera + ": " + error.what());
  } catch (...) {
    reportError("image", camera + ": image refused (unknown exception)");
  }
}

void NerfNode::pollFrames(const ros::TimerEvent&) {
  try {
    std::vector<std::string> dropped;
    std::vector<demnerf::core::Frame> fresh = intake_.poll(&dropped);
    for (const std::string& reason : dropped) reportError("tf", reason);
    if (fresh.empty()) return;
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& frame : fresh) {
      if (background_ && background_->running()) {
        try {
          background_->trainer().addFrame(frame);  // the trainer bounds its own store (setMaxFrames)
        } catch (const std::exception& error) {
          last_error_ = error.what();
        }
      }
      keyframes_.push_back(std::move(frame));
    }
    // The node's copy is bounded too: the oldest keyframes make room.
    while (keyframes_.size() > static_cast<std::size_t>(config_.max_frames)) keyframes_.erase(keyframes_.begin());
    if (!background_ && keyframes_.size() >= static_cast<std::size_t>(config_.min_frames)) startTraining();
  } catch (const std::exception& error) {
    reportError("internal", std::string("keyframe intake: ") + error.what());
  } catch (...) {
    reportError("internal", "keyframe intake: unknown exception");
  }
}

std::shared_ptr<const demnerf::nerf::NerfModel> NerfNode::currentModel() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (background_ && background_->running()) {
    return std::make_shared<const demnerf::nerf::NerfModel>(background_->trainer().snapshot());
  }
  return trained_;
}

void NerfNode::reportError(const std::string& cause, const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = message;
  }
  rejections_.count(cause, message);
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.stage = "error";
  status.message = message;
  status.rejections = rejections_.counts();
  status_publisher_.publish(status);
}

void NerfNode::publishStatus(const ros::TimerEvent&) {
  try {
    dem_nerf::TrainingStatus status;
    status.header.stamp = ros::Time::now();
    status.header.frame_id = config_.world_frame;
    const FrameIntakeCounts counts = intake_.counts();
    status.intake.received = static_cast<uint32_t>(counts.received);
    status.intake.keyframes = static_cast<uint32_t>(counts.keyframes);
    status.intake.not_new = static_cast<uint32_t>(counts.not_new);
    status.intake.rejected = static_cast<uint32_t>(counts.rejected);
    status.intake.tf_missing = static_cast<uint32_t>(counts.tf_missing);
    status.intake.tf_too_slow = static_cast<uint32_t>(counts.tf_too_slow);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status.stage = stage_;
      status.iteration = static_cast<uint32_t>(progress_.iteration);
      status.loss = static_cast<float>(progress_.loss);
      status.psnr = static_cast<float>(progress_.psnr);
      status.rays_per_second = static_cast<float>(progress_.rays_per_second);
      status.frames = static_cast<uint32_t>(keyframes_.size());
      status.message = describe(counts) + (resume_note_.empty() ? "" : "; " + resume_note_) +
                       (last_error_.empty() ? "" : " (last error: " + last_error_ + ")");
    }
    status.rejections = rejections_.counts();
    status_publisher_.publish(status);
    diagnostics_.update();  // takes mutex_ itself, in fillDiagnostics
    publishPreview();
  } catch (const std::exception& error) {  // a preview render that failed (torch, memory)
    reportError("internal", std::string("status/preview: ") + error.what());
  } catch (...) {
    reportError("internal", "status/preview: unknown exception");
  }
}

// Compute only when someone listens: the preview costs a render, so it runs only with subscribers.
void NerfNode::publishPreview() {
  if (preview_publisher_.getNumSubscribers() == 0) return;
  if ((ros::WallTime::now() - last_preview_).toSec() < 5.0) return;
  demnerf::core::Frame view;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (keyframes_.empty()) return;
    view = keyframes_.back();
  }
  const auto model = currentModel();
  if (!model) return;
  last_preview_ = ros::WallTime::now();
  demnerf::core::PinholeCamera camera = view.camera;
  if (std::max(camera.width, camera.height) > 128) camera = camera.downscaled(std::max(camera.width, camera.height) / 128.0);
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = view.file_path;
  const demnerf::nerf::RenderedImage image = demnerf::nerf::renderImage(*model, camera, view.world_from_camera);
  preview_publisher_.publish(toImageMessage(demnerf::nerf::toRgba(image), header));
}

void NerfNode::fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status.summary(last_error_.empty() ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN,
                 stage_ + (last_error_.empty() ? "" : ": " + last_error_));
  const FrameIntakeCounts counts = intake_.counts();
  status.add("images received", counts.received);
  status.add("keyframes", counts.keyframes);
  status.add("rejected", counts.rejected);
  status.add("tf missing", counts.tf_missing);
  status.add("tf too slow", counts.tf_too_slow);
  status.add("iteration", progress_.iteration);
  status.add("psnr", progress_.psnr);
}

}  // namespace dem_nerf
