#include "nodes/dem/dem_node.hpp"

#include <dem_nerf/TrainingStatus.h>
#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <sstream>

#include "conversions/cloud_conversions.hpp"
#include "conversions/marker_conversions.hpp"
#include "conversions/region_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/wrench_load.hpp"
#include "demnerf/geometry/regions.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

// A cloud whose particles fill less than 1/1000 of their bounding box has an outlier (a huge but
// finite coordinate, or a wrong unit): refused before a solver sizes a grid or mesh over the box,
// which would take all the memory. Volumes as given (unit volumes of x y z clouds pass).
void checkSpread(const demnerf::core::ParticleCloud& cloud) {
  Eigen::AlignedBox3d box;
  double volume = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    box.extend(cloud.positions[i]);
    volume += cloud.volumes[i];
  }
  const Eigen::Vector3d size = box.sizes();
  const double spacing = std::cbrt(volume / static_cast<double>(cloud.size()));
  // Each side padded by a particle spacing, so that flat or single-particle clouds are not refused.
  const double box_volume = (size.x() + spacing) * (size.y() + spacing) * (size.z() + spacing);
  if (!(volume > 0.0) || !std::isfinite(box_volume) || box_volume > 1000.0 * volume) {
    std::ostringstream text;
    text.precision(3);
    text << "the particles (total volume " << volume << " m^3) are spread over a box of " << size.x() << " x "
         << size.y() << " x " << size.z() << " m: an outlier coordinate or wrong volumes";
    throw Error(text.str());
  }
}

}  // namespace

DemNode::DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config)
    : config_(config), tf_listener_(tf_buffer_) {
  status_publisher_ = private_node.advertise<dem_nerf::TrainingStatus>("status", 10, true);
  displaced_publisher_ = private_node.advertise<sensor_msgs::PointCloud2>("displaced", 1, true);
  markers_publisher_ = private_node.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  image_transport::ImageTransport private_transport(private_node);
  rendered_publisher_ = private_transport.advertise(
      "rendered", 1, [this](const image_transport::SingleSubscriberPublisher& peer) { onRenderSubscriber(peer); });
  render_worker_ = std::make_unique<LatestWinsWorker<RenderJob>>([this](const RenderJob& job) { runRender(job); });
  const auto min_interval = config_.max_solve_rate > 0
                                ? std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(1.0 / config_.max_solve_rate))
                                : std::chrono::steady_clock::duration::zero();
  worker_ = std::make_unique<LatestWinsWorker<SolveJob>>([this](const SolveJob& job) { runSolve(job); }, min_interval);

  if (config_.scenario.empty()) {
    reportError("scenario", "no ~scenario set: give a scenario YAML with the material (see config/scenarios/)");
  } else {
    try {
      scenario_ = demnerf::core::loadScenario(config_.scenario);
      scenario_loaded_ = true;
    } catch (const std::exception& error) {
      reportError("scenario", error.what());
    }
  }
  startLiveSettings(private_node);  // before anything can ask for a solve
  ros::NodeHandle service_node(private_node);
  service_node.setCallbackQueue(&service_queue_);
  solve_service_ = service_node.advertiseService("solve", &DemNode::solve, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();
  particles_subscriber_ = node.subscribe("particles", 1, &DemNode::onParticles, this);
  fixtures_subscriber_ = private_node.subscribe("fixtures", 1, &DemNode::onFixtures, this);
  wrench_subscriber_ = private_node.subscribe("wrench", 10, &DemNode::onWrench, this);
  load_case_subscriber_ = private_node.subscribe("load_case", 1, &DemNode::onLoadCase, this);
  model_subscriber_ = node.subscribe("model", 1, &DemNode::onModel, this);
  render_camera_info_subscriber_ =
      private_node.subscribe("render_camera_info", 1, &DemNode::onRenderCameraInfo, this);
  status_timer_ = private_node.createTimer(ros::Duration(1.0), &DemNode::publishPeriodicStatus, this);
  ROS_INFO("dem_node: solver %s, scenario '%s'", config_.solver.c_str(), config_.scenario.c_str());
}

DemNode::~DemNode() {
  shutting_down_ = true;
  cancel_ = true;  // a running solve stops at its next check
  if (service_spinner_) service_spinner_->stop();  // a waiting ~solve caller is answered first
  solve_service_.shutdown();  // before its queue goes
  service_queue_.disable();
  service_queue_.clear();
}

void DemNode::onParticles(const sensor_msgs::PointCloud2ConstPtr& message) {
  try {
    demnerf::core::ParticleCloud cloud =
        particlesFromPointCloud2(*message, static_cast<std::uint64_t>(config_.max_particles));
    toParticlesFrame(cloud, message->header);
    checkSpread(cloud);
    demnerf::core::Scenario scenario;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      particles_ = cloud;
      ++particles_generation_;
      scenario = scenario_;
    }
    if (push_) push_->setBody(cloud, scenario);
    requestSolve("new particles");
  } catch (const std::exception& error) {  // core::Error from the checks; bad_alloc; tf
    reportError("particles", std::string("particles rejected: ") + error.what());
  } catch (...) {
    reportError("particles", "particles rejected: unknown exception");
  }
}

void DemNode::toParticlesFrame(demnerf::core::ParticleCloud& cloud, const std_msgs::Header& header) {
  if (header.frame_id.empty() || header.frame_id == config_.particles_frame) return;
  std::string why;
  if (!tf_buffer_.canTransform(config_.particles_frame, header.frame_id, ros::Time(0),
                               ros::Duration(config_.tf_timeout), &why)) {
    throw Error("the cloud is in frame '" + header.frame_id + "' and there is no tf to ~particles_frame '" +
                config_.particles_frame + "': " + why);
  }
  const Eigen::Isometry3d pose =
      tf2::transformToEigen(tf_buffer_.lookupTransform(config_.particles_frame, header.frame_id, ros::Time(0)));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    cloud.positions[i] = pose * cloud.positions[i];
    cloud.normals[i] = pose.linear() * cloud.normals[i];
  }
  cloud.validate();
}

void DemNode::requireParticlesFrame(const std::string& frame_id, const std::string& what) const {
  if (!frame_id.empty() && frame_id != config_.particles_frame)
    throw Error(what + " is in frame '" + frame_id + "', but regions are read in ~particles_frame '" +
                config_.particles_frame + "' (give them there, or leave frame_id empty)");
}

void DemNode::onFixtures(const dem_nerf::FixtureArrayConstPtr& message) {
  try {
    requireParticlesFrame(message->header.frame_id, "the fixture array");
    if (message->fixtures.empty()) {
      // The message replaces any earlier set: an empty one clears them, and nothing is solved
      // until fixtures arrive (a body without supports has no equilibrium).
      {
        std::lock_guard<std::mutex> lock(mutex_);
        scenario_.fixtures.clear();
      }
      publishStatus("idle", "fixtures cleared by an empty FixtureArray: no solve until fixtures arrive");
      return;
    }
    dem_nerf::LoadCase load_case;
    load_case.fixtures = message->fixtures;
    const demnerf::core::Scenario scenario = scenarioFor(load_case);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_.fixtures = scenario.fixtures;
    }
    requestSolve("new fixtures");
  } catch (const std::exception& error) {
    reportError("fixtures", std::string("fixtures rejected: ") + error.what());
  } catch (...) {
    reportError("fixtures", "fixtures rejected: unknown exception");
  }
}

void DemNode::onWrench(const geometry_msgs::WrenchStampedConstPtr& message) {
  try {
    const auto& w = message->wrench;
    const Eigen::Vector3d force(w.force.x, w.force.y, w.force.z), torque(w.torque.x, w.torque.y, w.torque.z);
    if (!force.allFinite() || !torque.allFinite()) throw Error("it holds NaN or Inf");
    if (message->header.frame_id.empty()) throw Error("its frame_id is empty (the wrench acts at its frame's origin)");
    std::string why;
    if (!tf_buffer_.canTransform(config_.particles_frame, message->header.frame_id, message->header.stamp,
                                 ros::Duration(config_.tf_timeout), &why)) {
      throw Error("no tf from '" + config_.particles_frame + "' to the wrench frame '" + message->header.frame_id +
                  "': " + why);
    }
    const Eigen::Isometry3d pose = tf2::transformToEigen(
        tf_buffer_.lookupTransform(config_.particles_frame, message->header.frame_id, message->header.stamp));
    // The wrench acts at its frame's origin on the surface particles within ~contact_radius.
    const demnerf::core::Load load = demnerf::core::loadFromWrench(pose, force, torque, config_.contact_radius,
                                                                   "wrench in " + message->header.frame_id);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_.loads = {load};
    }
    requestSolve("wrench");
  } catch (const std::exception& error) {  // core::Error; tf2 exceptions
    reportError("wrench", std::string("wrench rejected: ") + error.what());
  } catch (...) {
    reportError("wrench", "wrench rejected: unknown exception");
  }
}

void DemNode::onLoadCase(const dem_nerf::LoadCaseConstPtr& message) {
  try {
    requireParticlesFrame(message->header.frame_id, "the load case");
    const demnerf::core::Scenario scenario = scenarioFor(*message);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_ = scenario;
    }
    requestSolve("load case");
  } catch (const std::exception& error) {
    reportError("load_case", std::string("load case rejected: ") + error.what());
  } catch (...) {
    reportError("load_case", "load case rejected: unknown exception");
  }
}

demnerf::core::Scenario DemNode::scenarioFor(const dem_nerf::LoadCase& load_case) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!scenario_loaded_) throw Error("no valid ~scenario loaded, so no material is known");
  if (!particles_) throw Error("no particle cloud received yet on 'particles'");
  demnerf::core::Scenario scenario = scenario_;
  if (!load_case.fixtures.empty()) {
    scenario.fixtures.clear();
    for (const auto& fixture : load_case.fixtures) scenario.fixtures.push_back(fromMessage(fixture));
  }
  if (!load_case.loads.empty()) {
    scenario.loads.clear();
    for (const auto& load : load_case.loads) scenario.loads.push_back(fromMessage(load));
  }
  // The load case's body force replaces the current one; zero clears it (LoadCase.msg).
  scenario.body_force = Eigen::Vector3d(load_case.body_force.x, load_case.body_force.y, load_case.body_force.z);
  if (!scenario.body_force.allFinite()) throw Error("body_force holds NaN or Inf");
  scenario.validate("load case");
  for (const auto& fixture : scenario.fixtures) {
    demnerf::geometry::selectParticles(*particles_, fixture.region, "fixture '" + fixture.name + "'");
  }
  return scenario;
}

void DemNode::publishResult(const demnerf::mechanics::SimulationOutcome& outcome,
                            const demnerf::core::Scenario& scenario) {
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = config_.particles_frame;
  displaced_publisher_.publish(toPointCloud2(outcome.field, header, /*displaced_positions=*/true));
  markers_publisher_.publish(resultMarkers(scenario, config_.particles_frame));
  requestRender(outcome.field);
}

}  // namespace dem_nerf
