#include "nodes/nerf/nerf_node.hpp"

#include <cv_bridge/cv_bridge.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/Marker.h>

#include <filesystem>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "pipeline/model_geometry.hpp"

namespace dem_nerf {
namespace {

std::string describe(const FrameIntakeCounts& counts) {
  return std::to_string(counts.received) + " images: " + std::to_string(counts.keyframes) + " keyframes, " +
         std::to_string(counts.not_new) + " too close to a keyframe, " + std::to_string(counts.rejected) +
         " rejected, " + std::to_string(counts.tf_missing) + " without tf, " + std::to_string(counts.tf_too_slow) +
         " with tf too slow";
}

FrameIntakeConfig intakeConfig(const NerfNodeConfig& config) {
  FrameIntakeConfig intake;
  intake.world_frame = config.world_frame;
  intake.tf_timeout = config.tf_timeout;
  intake.max_image_size = config.max_image_size;
  intake.max_input_pixels = static_cast<std::uint64_t>(config.max_input_pixels);
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

demnerf::nerf::NerfConfig nerfConfig(const NerfNodeConfig& config) {
  demnerf::nerf::NerfConfig nerf =
      config.nerf_config.empty() ? demnerf::nerf::NerfConfig{} : demnerf::nerf::loadNerfConfig(config.nerf_config);
  nerf.train.threads = config.threads;
  nerf.validate();
  return nerf;
}

// The scene box: ~aabb when given, else where the keyframes' cameras look.
demnerf::nerf::Box sceneBox(const NerfNodeConfig& config, const std::vector<demnerf::core::Frame>& frames) {
  Eigen::AlignedBox3d box;
  if (!config.aabb.empty()) {
    box = Eigen::AlignedBox3d(Eigen::Vector3d(config.aabb[0], config.aabb[1], config.aabb[2]),
                              Eigen::Vector3d(config.aabb[3], config.aabb[4], config.aabb[5]));
  } else {
    box = demnerf::core::boundsFromCameras(frames);
  }
  return demnerf::nerf::toBox(box);
}

sensor_msgs::Image toImageMessage(const demnerf::nerf::RenderedImage& image, const std_msgs::Header& header) {
  cv::Mat bytes;
  demnerf::nerf::toRgba(image).convertTo(bytes, CV_8UC4, 255.0);
  return *cv_bridge::CvImage(header, sensor_msgs::image_encodings::RGBA8, bytes).toImageMsg();
}

visualization_msgs::Marker meshMarker(const demnerf::core::TriangleMesh& mesh, const std::string& frame) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "nerf_mesh";
  marker.type = visualization_msgs::Marker::TRIANGLE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = marker.scale.y = marker.scale.z = 1.0;
  marker.color.r = 0.8f;
  marker.color.g = 0.6f;
  marker.color.b = 0.4f;
  marker.color.a = 0.6f;
  for (const auto& face : mesh.faces) {
    for (int corner : face) {
      geometry_msgs::Point point;
      point.x = mesh.vertices[corner].x();
      point.y = mesh.vertices[corner].y();
      point.z = mesh.vertices[corner].z();
      marker.points.push_back(point);
    }
  }
  return marker;
}

demnerf::core::ParticleCloud sampleModel(const demnerf::nerf::NerfModel& model, const NerfNodeConfig& config,
                                         const std::string& sampler, double spacing,
                                         demnerf::core::TriangleMesh* mesh_out) {
  demnerf::geometry::MeshExtractionConfig extraction;
  if (config.density_threshold > 0.0) {
    extraction.surface = demnerf::geometry::SurfaceDefinition::kDensity;
    extraction.threshold = config.density_threshold;
  } else {
    extraction.surface = demnerf::geometry::SurfaceDefinition::kOpacity;
    extraction.opacity = config.surface_opacity;
  }
  const demnerf::core::TriangleMesh mesh = extractSurface(model, config.extract_resolution, extraction).mesh;
  demnerf::geometry::SamplerConfig sampling;
  sampling.method = demnerf::geometry::parseSamplingMethod(sampler);
  if (spacing <= 0.0) {
    Eigen::AlignedBox3d box;
    for (const auto& v : mesh.vertices) box.extend(v);
    spacing = box.diagonal().norm() / 40.0;
  }
  sampling.spacing = spacing;
  demnerf::core::ParticleCloud cloud = demnerf::geometry::sampleParticles(mesh, sampling, nullptr);
  colourFromModel(model, &cloud);
  if (mesh_out != nullptr) *mesh_out = mesh;
  return cloud;
}

}  // namespace

NerfNode::NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config)
    : config_(config),
      nerf_config_(nerfConfig(config)),
      tf_listener_(tf_buffer_),
      intake_(intakeConfig(config), tf_buffer_),
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
      const std::optional<TrainingRecord> record = loadTrainingRecord(config_.model_path);
      resumed_ = record.value_or(TrainingRecord{});
      resume_note_ = record ? "resumed from iteration " + std::to_string(resumed_.iteration) + " (" +
                                  std::to_string(static_cast<int>(resumed_.seconds)) + " s of training) of '" +
                                  config_.model_path + "'"
                            : "resumed the weights of '" + config_.model_path +
                                  "' (no training record beside it: the iteration count starts at 0)";
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

void NerfNode::startTraining() {
  try {
    std::unique_ptr<demnerf::nerf::Trainer> trainer =
        resume_from_ ? std::make_unique<demnerf::nerf::Trainer>(std::move(*resume_from_))
                     : std::make_unique<demnerf::nerf::Trainer>(nerf_config_, sceneBox(config_, keyframes_), 1.0);
    resume_from_.reset();
    trainer->setMaxFrames(static_cast<std::size_t>(config_.max_frames));
    trainer->addFrames(keyframes_);
    demnerf::nerf::BackgroundTrainerConfig background;
    // A resumed run continues the same budget. One already spent still trains a moment, so that
    // the usual end of training (model, particles, mesh) happens in this session too.
    background.stop.seconds =
        config_.train_seconds > 0 ? std::max(config_.train_seconds - resumed_.seconds, 1.0) : 0.0;
    background.stop.iterations =
        config_.max_iterations > 0 ? std::max<std::int64_t>(config_.max_iterations - resumed_.iteration, 1) : 0;
    // The node autosaves itself (in the progress callback) so that every model file gets a
    // training record with exactly its iteration; the background trainer only saves at the end.
    background.autosave_seconds = 0;
    background.model_path = config_.model_path;
    last_autosave_ = 0;
    demnerf::nerf::Trainer* live = trainer.get();  // owned by the background trainer from here on
    demnerf::nerf::BackgroundTrainerCallbacks callbacks;
    callbacks.progress = [this, live](const demnerf::nerf::TrainProgress& progress) {
      // Runs on the training thread between iterations, so the live model is consistent.
      if (config_.autosave_seconds > 0 && progress.seconds - last_autosave_ >= config_.autosave_seconds) {
        last_autosave_ = progress.seconds;
        autosave(live->model(), progress);
      }
      std::lock_guard<std::mutex> lock(mutex_);
      progress_ = overAllRuns(progress);
    };
    callbacks.done = [this](const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& progress) {
      onTrained(model, progress);
    };
    callbacks.error = [this](const std::string& message) { reportError("training", message); };
    background_ = std::make_unique<demnerf::nerf::BackgroundTrainer>(std::move(trainer), background, callbacks);
    stage_ = "training";
    ROS_INFO("nerf_node: training on %zu keyframes", keyframes_.size());
  } catch (const std::exception& error) {  // core::Error, and torch's c10::Error (out of memory)
    stage_ = "error";
    last_error_ = std::string("training could not start: ") + error.what();
    ROS_ERROR("nerf_node: %s", last_error_.c_str());
  }
}

// Runs on the training thread once training ends: the slow extraction stays off ROS callbacks.
void NerfNode::onTrained(const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& session) {
  auto trained = std::make_shared<const demnerf::nerf::NerfModel>(model);
  demnerf::nerf::TrainProgress progress;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress = overAllRuns(session);
    trained_ = trained;
    progress_ = progress;
    stage_ = "trained";
  }
  try {  // the background trainer has just written the final model file
    saveTrainingRecord(config_.model_path, {progress.iteration, progress.seconds, progress.psnr});
  } catch (const std::exception& error) {
    reportError("save", error.what());
  }
  ROS_INFO("nerf_node: trained, %lld iterations, training PSNR %.2f dB", static_cast<long long>(progress.iteration),
           progress.psnr);
  publishModel(trained, static_cast<std::uint32_t>(progress.iteration), static_cast<float>(progress.psnr));
}

void NerfNode::autosave(const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& session) {
  TrainingRecord record;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const demnerf::nerf::TrainProgress progress = overAllRuns(session);
    record = {progress.iteration, progress.seconds, progress.psnr};
  }
  try {
    demnerf::nerf::saveModel(model, config_.model_path);
    saveTrainingRecord(config_.model_path, record);
  } catch (const std::exception& error) {
    // A full disk must not end training: report it; the previous files stay as they were.
    reportError("save", std::string("autosave failed: ") + error.what());
  }
}

demnerf::nerf::TrainProgress NerfNode::overAllRuns(demnerf::nerf::TrainProgress progress) {
  progress.iteration += resumed_.iteration;
  progress.seconds += resumed_.seconds;
  return progress;
}

void NerfNode::publishModel(std::shared_ptr<const demnerf::nerf::NerfModel> model, std::uint32_t iteration,
                            float psnr) {
  dem_nerf::ModelInfo info;
  info.header.stamp = ros::Time::now();
  info.header.frame_id = config_.world_frame;
  info.model_path = std::filesystem::absolute(config_.model_path).string();
  const demnerf::nerf::Box box = model->bounds();
  info.aabb_min.x = box.min[0];
  info.aabb_min.y = box.min[1];
  info.aabb_min.z = box.min[2];
  info.aabb_max.x = box.max[0];
  info.aabb_max.y = box.max[1];
  info.aabb_max.z = box.max[2];
  info.iteration = iteration;
  info.psnr = psnr;
  model_publisher_.publish(info);
  try {
    demnerf::core::TriangleMesh mesh;
    const demnerf::core::ParticleCloud cloud =
        sampleModel(*model, config_, config_.sampler, config_.particle_spacing, &mesh);
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = config_.world_frame;
    particles_publisher_.publish(toPointCloud2(cloud, header));
    mesh_publisher_.publish(meshMarker(mesh, config_.world_frame));
    ROS_INFO("nerf_node: published %zu particles and a mesh of %zu faces", cloud.size(), mesh.faces.size());
  } catch (const std::exception& error) {  // core::Error, torch or CGAL errors on an odd model
    reportError("extract", std::string("no particles from the trained model: ") + error.what());
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
  preview_publisher_.publish(toImageMessage(demnerf::nerf::renderImage(*model, camera, view.world_from_camera), header));
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

bool NerfNode::render(dem_nerf::RenderView::Request& request, dem_nerf::RenderView::Response& response) {
  try {
    const auto model = currentModel();
    if (!model) throw demnerf::core::Error("no model yet: training has not started (waiting for keyframes)");
    const demnerf::core::PinholeCamera camera = fromCameraInfo(request.camera_info);
    const std::uint64_t pixels = std::uint64_t(request.camera_info.width) * request.camera_info.height;
    if (pixels > static_cast<std::uint64_t>(config_.max_render_pixels))
      throw demnerf::core::Error("render of " + std::to_string(request.camera_info.width) + "x" +
                                 std::to_string(request.camera_info.height) + " refused: more than ~max_render_pixels = " +
                                 std::to_string(config_.max_render_pixels) + " pixels");
    const auto& q = request.pose.orientation;
    const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
    if (!rotation.coeffs().allFinite() || rotation.norm() < 1e-6)
      throw demnerf::core::Error("pose orientation is not a rotation (a zero, NaN or Inf quaternion)");
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotation.normalized().toRotationMatrix();  // tf2::fromMsg would not normalise
    pose.translation() = Eigen::Vector3d(request.pose.position.x, request.pose.position.y, request.pose.position.z);
    if (!pose.matrix().allFinite()) throw demnerf::core::Error("pose holds NaN or Inf");
    std_msgs::Header header = request.camera_info.header;
    response.image = toImageMessage(demnerf::nerf::renderImage(*model, camera, pose), header);
    response.ok = true;
    response.message = "rendered " + std::to_string(camera.width) + "x" + std::to_string(camera.height);
  } catch (const std::exception& error) {
    response.ok = false;
    response.message = error.what();
    rejections_.count("render", std::string("~render: ") + error.what());
  } catch (...) {
    response.ok = false;
    response.message = "render failed (unknown exception)";
    rejections_.count("render", response.message);
  }
  return true;
}

bool NerfNode::extract(dem_nerf::ExtractParticles::Request& request, dem_nerf::ExtractParticles::Response& response) {
  try {
    const auto model = currentModel();
    if (!model) throw demnerf::core::Error("no model yet: training has not started (waiting for keyframes)");
    const std::string sampler = request.sampler.empty() ? config_.sampler : request.sampler;
    if (!std::isfinite(request.spacing) || request.spacing < 0) throw demnerf::core::Error("spacing must be >= 0 m");
    const demnerf::core::ParticleCloud cloud = sampleModel(*model, config_, sampler, request.spacing, nullptr);
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = config_.world_frame;
    response.cloud = toPointCloud2(cloud, header);
    response.ok = true;
    response.message = std::to_string(cloud.size()) + " particles";
  } catch (const std::exception& error) {
    response.ok = false;
    response.message = error.what();
    rejections_.count("extract", std::string("~extract: ") + error.what());
  } catch (...) {
    response.ok = false;
    response.message = "extraction failed (unknown exception)";
    rejections_.count("extract", response.message);
  }
  return true;
}

bool NerfNode::save(dem_nerf::SaveModel::Request& request, dem_nerf::SaveModel::Response& response) {
  try {
    const auto model = currentModel();
    if (!model) throw demnerf::core::Error("nothing to save: training has not started (waiting for keyframes)");
    const std::string path = request.path.empty() ? config_.model_path : request.path;
    demnerf::nerf::saveModel(*model, path);
    response.ok = true;
    response.message = "saved to " + path;
  } catch (const std::exception& error) {
    response.ok = false;
    response.message = error.what();
    rejections_.count("save", std::string("~save: ") + error.what());
  } catch (...) {
    response.ok = false;
    response.message = "save failed (unknown exception)";
    rejections_.count("save", response.message);
  }
  return true;
}

bool NerfNode::load(dem_nerf::LoadModel::Request& request, dem_nerf::LoadModel::Response& response) {
  try {
    auto model = std::make_shared<const demnerf::nerf::NerfModel>(demnerf::nerf::loadModel(request.path));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (background_ && background_->running()) {
        throw demnerf::core::Error("training is running; call ~reset first, then load");
      }
      trained_ = model;
      stage_ = "trained";
    }
    publishModel(model, 0, 0.0f);
    response.ok = true;
    response.message = "loaded " + request.path;
  } catch (const std::exception& error) {  // core::Error, and whatever a garbage file makes torch throw
    response.ok = false;
    response.message = error.what();  // the model in use, if any, is kept
    reportError("load", response.message);
  } catch (...) {
    response.ok = false;
    response.message = "load failed (unknown exception); the model in use is kept";
    reportError("load", response.message);
  }
  return true;
}

bool NerfNode::reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  std::unique_ptr<demnerf::nerf::BackgroundTrainer> background;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    background = std::move(background_);
  }
  background.reset();  // stops training (it saves a last time) before the state is cleared
  intake_.reset();
  std::lock_guard<std::mutex> lock(mutex_);
  keyframes_.clear();
  trained_.reset();
  resume_from_.reset();
  resumed_ = {};
  resume_note_.clear();
  progress_ = {};
  stage_ = "waiting_for_frames";
  last_error_.clear();
  response.success = true;
  response.message = "training stopped; keyframes and model cleared";
  return true;
}

}  // namespace dem_nerf
