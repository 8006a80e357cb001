// nerf_node's training side: the background trainer started once enough keyframes arrived (or
// resumed from the model file), its autosaves with their training record, and what the trained
// model publishes (ModelInfo, particles, mesh).
#include <dem_nerf/ModelInfo.h>

#include <filesystem>

#include "conversions/cloud_conversions.hpp"
#include "conversions/marker_conversions.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "nodes/nerf/nerf_node.hpp"
#include "pipeline/model_geometry.hpp"

namespace dem_nerf {
namespace {

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

}  // namespace

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
    // The node autosaves itself (in the progress callback, the error counted under "save"); the
    // background trainer saves at the end, its header's record continuing resumed_.
    background.autosave_seconds = 0;
    background.model_path = config_.model_path;
    background.earlier = resumed_;
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
  ROS_INFO("nerf_node: trained, %lld iterations, training PSNR %.2f dB", static_cast<long long>(progress.iteration),
           progress.psnr);
  publishModel(trained, static_cast<std::uint32_t>(progress.iteration), static_cast<float>(progress.psnr));
}

void NerfNode::autosave(const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& session) {
  demnerf::nerf::TrainingRecord record;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const demnerf::nerf::TrainProgress progress = overAllRuns(session);
    record = {progress.iteration, progress.seconds, progress.psnr};
  }
  try {
    demnerf::nerf::saveModel(model, config_.model_path, record);
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
    const SurfaceConfig extraction = extractionConfig();
    const demnerf::core::ParticleCloud cloud = particlesFromModel(*model, extraction, config_.sampling, &mesh);
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = config_.world_frame;
    particles_publisher_.publish(toPointCloud2(cloud, header));
    mesh_publisher_.publish(meshMarker(mesh, config_.world_frame));
    const std::size_t carved = extraction.mesh.solid.cameras.size();
    const std::string note = carved ? ", carved against " + std::to_string(carved) + " keyframes" : "";
    ROS_INFO("nerf_node: published %zu particles and a mesh of %zu faces%s", cloud.size(), mesh.faces.size(),
             note.c_str());
  } catch (const std::exception& error) {  // core::Error, torch or CGAL errors on an odd model
    reportError("extract", std::string("no particles from the trained model: ") + error.what());
  }
}

}  // namespace dem_nerf
