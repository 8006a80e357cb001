#include "nodes/dem/dem_node.hpp"

#include <dem_nerf/TrainingStatus.h>
#include <visualization_msgs/MarkerArray.h>

#include "conversions/cloud_conversions.hpp"
#include "conversions/region_conversions.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

const char* kNotBuilt = "the simulation stage is not built yet in this version of dem_nerf";

}  // namespace

DemNode::DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config)
    : config_(config) {
  status_publisher_ = private_node.advertise<dem_nerf::TrainingStatus>("status", 10, true);
  displaced_publisher_ = private_node.advertise<sensor_msgs::PointCloud2>("displaced", 1, true);
  markers_publisher_ = private_node.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  image_transport::ImageTransport private_transport(private_node);
  rendered_publisher_ = private_transport.advertise("rendered", 1);
  solve_service_ = private_node.advertiseService("solve", &DemNode::solve, this);
  particles_subscriber_ = node.subscribe("particles", 1, &DemNode::onParticles, this);
  fixtures_subscriber_ = private_node.subscribe("fixtures", 1, &DemNode::onFixtures, this);
  wrench_subscriber_ = private_node.subscribe("wrench", 1, &DemNode::onWrench, this);
  load_case_subscriber_ = private_node.subscribe("load_case", 1, &DemNode::onLoadCase, this);
  model_subscriber_ = node.subscribe("model", 1, &DemNode::onModel, this);
  status_timer_ = private_node.createTimer(ros::Duration(1.0), &DemNode::publishPeriodicStatus, this);

  if (config_.scenario.empty()) {
    reportError("no ~scenario set: give a scenario YAML with the material (see config/scenarios/)");
  } else {
    try {
      scenario_ = demnerf::core::loadScenario(config_.scenario);
      scenario_loaded_ = true;
    } catch (const demnerf::core::Error& error) {
      reportError(error.what());
    }
  }
  ROS_INFO("dem_node: solver %s; %s", config_.solver.c_str(), kNotBuilt);
}

void DemNode::onParticles(const sensor_msgs::PointCloud2ConstPtr& message) {
  try {
    demnerf::core::ParticleCloud cloud = particlesFromPointCloud2(*message);
    std::lock_guard<std::mutex> lock(mutex_);
    particles_ = std::move(cloud);
  } catch (const demnerf::core::Error& error) {
    reportError(std::string("particles rejected: ") + error.what());
  }
}

void DemNode::onFixtures(const dem_nerf::FixtureArrayConstPtr& message) {
  try {
    for (const auto& fixture : message->fixtures) fromMessage(fixture);
  } catch (const demnerf::core::Error& error) {
    reportError(std::string("fixtures rejected: ") + error.what());
  }
}

void DemNode::onWrench(const geometry_msgs::WrenchStampedConstPtr& message) {
  const auto& w = message->wrench;
  for (double v : {w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z}) {
    if (!std::isfinite(v)) {
      reportError("wrench rejected: it holds NaN or Inf");
      return;
    }
  }
  publishStatus("idle", std::string("wrench received; ") + kNotBuilt);
}

void DemNode::onLoadCase(const dem_nerf::LoadCaseConstPtr& message) {
  try {
    scenarioFor(*message);
    publishStatus("idle", std::string("load case accepted; ") + kNotBuilt);
  } catch (const demnerf::core::Error& error) {
    reportError(std::string("load case rejected: ") + error.what());
  }
}

void DemNode::onModel(const dem_nerf::ModelInfoConstPtr&) {}

demnerf::core::Scenario DemNode::scenarioFor(const dem_nerf::LoadCase& load_case) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!scenario_loaded_) throw demnerf::core::Error("no valid ~scenario loaded, so no material is known");
  if (!particles_) throw demnerf::core::Error("no particle cloud received yet on 'particles'");
  demnerf::core::Scenario scenario = scenario_;
  if (!load_case.fixtures.empty()) {
    scenario.fixtures.clear();
    for (const auto& fixture : load_case.fixtures) scenario.fixtures.push_back(fromMessage(fixture));
  }
  if (!load_case.loads.empty()) {
    scenario.loads.clear();
    for (const auto& load : load_case.loads) scenario.loads.push_back(fromMessage(load));
  }
  scenario.body_force = {load_case.body_force.x, load_case.body_force.y, load_case.body_force.z};
  scenario.validate("load case");
  for (const auto& fixture : scenario.fixtures) {
    bool selects = false;
    for (const auto& p : particles_->positions) selects = selects || fixture.region.contains(p);
    if (!selects) {
      throw demnerf::core::Error("fixture '" + fixture.name + "' selects no particles: region " +
                                 fixture.region.describe());
    }
  }
  return scenario;
}

bool DemNode::solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response) {
  try {
    scenarioFor(request.load_case);
    response.ok = false;
    response.message = kNotBuilt;
  } catch (const demnerf::core::Error& error) {
    response.ok = false;
    response.message = error.what();
    reportError(error.what());
  }
  return true;
}

void DemNode::publishStatus(const std::string& stage, const std::string& message) {
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.stage = stage;
  status.message = message;
  status_publisher_.publish(status);
}

void DemNode::reportError(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = message;
  }
  ROS_WARN_THROTTLE(5.0, "dem_node: %s", message.c_str());
  publishStatus("error", message);
}

void DemNode::publishPeriodicStatus(const ros::TimerEvent&) {
  std::string message;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    message = (particles_ ? std::to_string(particles_->size()) + " particles" : std::string("no particles yet")) +
              (last_error_.empty() ? "" : "; last error: " + last_error_);
  }
  publishStatus("idle", message + "; " + kNotBuilt);
}

}  // namespace dem_nerf
