// nerf_node's services: render a view, extract particles, save, load and reset the model. They run
// on their own callback queue, so a slow render never holds up the image intake.
#include <Eigen/Geometry>

#include <cmath>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "conversions/image_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "nodes/nerf/nerf_node.hpp"
#include "pipeline/model_geometry.hpp"

namespace dem_nerf {

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
    response.image = toImageMessage(demnerf::nerf::toRgba(demnerf::nerf::renderImage(*model, camera, pose)), header);
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
    if (!std::isfinite(request.spacing) || request.spacing < 0) throw demnerf::core::Error("spacing must be >= 0 m");
    demnerf::geometry::SamplerConfig sampling = config_.sampling;  // ~sampling, unless the request says
    if (!request.sampler.empty()) sampling.method = demnerf::geometry::parseSamplingMethod(request.sampler);
    if (request.spacing > 0) sampling.spacing = request.spacing;
    const demnerf::core::ParticleCloud cloud = particlesFromModel(*model, extractionConfig(), sampling);
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

SurfaceConfig NerfNode::extractionConfig() {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    return withTrainingCameras(config_.extraction, keyframes_, "nerf_node's keyframes");
  } catch (const demnerf::core::Error& error) {
    throw demnerf::core::Error(std::string("~extraction: ") + error.what() +
                               " (the keyframes are the images this session trains on; a model from ~load brings no "
                               "cameras; ~extraction/solid_views 0 extracts without carving)");
  }
}

bool NerfNode::save(dem_nerf::SaveModel::Request& request, dem_nerf::SaveModel::Response& response) {
  try {
    const auto model = currentModel();
    if (!model) throw demnerf::core::Error("nothing to save: training has not started (waiting for keyframes)");
    const std::string path = request.path.empty() ? config_.model_path : request.path;
    std::optional<demnerf::nerf::TrainingRecord> record;  // none before any training step
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (progress_.iteration > 0) record = demnerf::nerf::TrainingRecord{progress_.iteration, progress_.seconds, progress_.psnr};
    }
    if (record) demnerf::nerf::saveModel(*model, path, *record);
    else demnerf::nerf::saveModel(*model, path);
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
