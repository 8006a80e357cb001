#include "nodes/recorder/demo_recorder.hpp"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "conversions/cloud_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"

namespace dem_nerf {

DemoRecorderConfig DemoRecorderConfig::fromParameters(const ros::NodeHandle& private_node) {
  DemoRecorderConfig config;
  private_node.param("out_dir", config.out_dir, config.out_dir);
  private_node.param("timeout", config.timeout, config.timeout);
  if (config.out_dir.empty()) throw demnerf::core::Error("parameter ~out_dir is required (where the files go)");
  if (!(config.timeout > 0)) throw demnerf::core::Error("parameter ~timeout must be positive seconds");
  return config;
}

DemoRecorder::DemoRecorder(ros::NodeHandle node, ros::NodeHandle private_node, DemoRecorderConfig config)
    : config_(std::move(config)), start_(ros::WallTime::now()) {
  std::filesystem::create_directories(config_.out_dir);
  particles_subscriber_ = node.subscribe("particles", 1, &DemoRecorder::onParticles, this);
  model_subscriber_ = node.subscribe("model", 1, &DemoRecorder::onModel, this);
  displaced_subscriber_ = node.subscribe("displaced", 1, &DemoRecorder::onDisplaced, this);
  timeout_timer_ = private_node.createWallTimer(ros::WallDuration(config_.timeout), &DemoRecorder::onTimeout, this, true);
  ROS_INFO("demo_recorder: waiting for particles, model and the displaced cloud (files go to %s)",
           config_.out_dir.c_str());
}

void DemoRecorder::onParticles(const sensor_msgs::PointCloud2ConstPtr& message) {
  try {
    const demnerf::core::ParticleCloud cloud = particlesFromPointCloud2(*message);
    demnerf::core::writeParticles(config_.out_dir + "/particles.ply", cloud);
    particle_count_ = cloud.size();
    particles_seconds_ = sinceStart();
    ROS_INFO("demo_recorder: %zu particles after %.1f s", particle_count_, particles_seconds_);
  } catch (const demnerf::core::Error& e) {
    ROS_ERROR("demo_recorder: particle cloud not written: %s", e.what());
  }
}

void DemoRecorder::onModel(const dem_nerf::ModelInfoConstPtr& message) {
  model_ = *message;
  model_seconds_ = sinceStart();
}

void DemoRecorder::onDisplaced(const sensor_msgs::PointCloud2ConstPtr& message) {
  if (complete_) return;
  try {
    const demnerf::core::ResultField field = resultFromPointCloud2(*message, /*displaced_positions=*/true);
    demnerf::core::writeResult(config_.out_dir + "/displaced.ply", field);
    for (const auto& u : field.displacements) max_displacement_ = std::max(max_displacement_, u.norm());
    displaced_seconds_ = sinceStart();
    complete_ = true;
    writeSummary("complete");
    ROS_INFO("demo_recorder: displaced cloud after %.1f s (max |u| %.4f m); done", displaced_seconds_,
             max_displacement_);
    ros::shutdown();
  } catch (const demnerf::core::Error& e) {
    ROS_ERROR("demo_recorder: displaced cloud not written: %s", e.what());
  }
}

void DemoRecorder::onTimeout(const ros::WallTimerEvent&) {
  const std::string missing = particles_seconds_ < 0 ? "nerf_node's particles" : "dem_node's displaced cloud";
  ROS_ERROR("demo_recorder: %s did not arrive within %.0f s; giving up", missing.c_str(), config_.timeout);
  writeSummary("timed out waiting for " + missing);
  ros::shutdown();
}

void DemoRecorder::writeSummary(const std::string& outcome) const {
  const nlohmann::json summary = {{"outcome", outcome},
                                  {"seconds_to_particles", particles_seconds_},
                                  {"seconds_to_model", model_seconds_},
                                  {"seconds_to_displaced", displaced_seconds_},
                                  {"particles", particle_count_},
                                  {"max_displacement", max_displacement_},
                                  {"model_path", model_.model_path},
                                  {"training_iterations", model_.iteration},
                                  {"training_psnr", model_.psnr}};
  std::ofstream(config_.out_dir + "/recorder.json") << summary.dump() << "\n";
}

}  // namespace dem_nerf
