#include "nodes/dem/dem_node.hpp"

#include <cv_bridge/cv_bridge.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include <sstream>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "conversions/region_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/geometry/regions.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

std::string describe(const demnerf::mechanics::SimulationOutcome& outcome) {
  std::ostringstream text;
  text.precision(4);
  text << outcome.field.size() << " particles, max displacement " << outcome.max_displacement * 1000.0
       << " mm, energy " << outcome.energy << " J, " << outcome.seconds << " s";
  return text.str();
}

visualization_msgs::Marker regionMarker(const demnerf::core::Region& region, const std::string& frame, int id,
                                        float r, float g, float b) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "fixtures";
  marker.id = id;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.position.x = region.center.x();
  marker.pose.position.y = region.center.y();
  marker.pose.position.z = region.center.z();
  marker.pose.orientation.w = 1.0;
  if (region.type == demnerf::core::Region::Type::kSphere) {
    marker.type = visualization_msgs::Marker::SPHERE;
    marker.scale.x = marker.scale.y = marker.scale.z = 2.0 * region.radius;
  } else {
    marker.type = visualization_msgs::Marker::CUBE;
    const Eigen::Vector3d size =
        region.type == demnerf::core::Region::Type::kBox ? region.size : Eigen::Vector3d::Constant(0.01);
    marker.scale.x = size.x();
    marker.scale.y = size.y();
    marker.scale.z = size.z();
  }
  marker.color.r = r;
  marker.color.g = g;
  marker.color.b = b;
  marker.color.a = 0.4f;
  return marker;
}

// Force arrows start at the load patch and are drawn 0.05 m long per newton of the largest load.
visualization_msgs::Marker forceArrow(const demnerf::core::Load& load, const std::string& frame, int id, double scale) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "loads";
  marker.id = id;
  marker.type = visualization_msgs::Marker::ARROW;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  geometry_msgs::Point tail, head;
  tail.x = load.region.center.x();
  tail.y = load.region.center.y();
  tail.z = load.region.center.z();
  const Eigen::Vector3d tip = load.region.center + scale * load.force;
  head.x = tip.x();
  head.y = tip.y();
  head.z = tip.z();
  marker.points = {tail, head};
  marker.scale.x = 0.005;
  marker.scale.y = 0.01;
  marker.scale.z = 0.015;
  marker.color.r = 1.0f;
  marker.color.g = 0.3f;
  marker.color.a = 1.0f;
  return marker;
}

}  // namespace

DemNode::DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config)
    : config_(config), solver_(demnerf::mechanics::parseSolverChoice(config.solver)), tf_listener_(tf_buffer_) {
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
    reportError("no ~scenario set: give a scenario YAML with the material (see config/scenarios/)");
  } else {
    try {
      scenario_ = demnerf::core::loadScenario(config_.scenario);
      scenario_loaded_ = true;
    } catch (const Error& error) {
      reportError(error.what());
    }
  }
  solve_service_ = private_node.advertiseService("solve", &DemNode::solve, this);
  particles_subscriber_ = node.subscribe("particles", 1, &DemNode::onParticles, this);
  fixtures_subscriber_ = private_node.subscribe("fixtures", 1, &DemNode::onFixtures, this);
  wrench_subscriber_ = private_node.subscribe("wrench", 10, &DemNode::onWrench, this);
  load_case_subscriber_ = private_node.subscribe("load_case", 1, &DemNode::onLoadCase, this);
  model_subscriber_ = node.subscribe("model", 1, &DemNode::onModel, this);
  render_camera_info_subscriber_ =
      private_node.subscribe("render_camera_info", 1, &DemNode::onRenderCameraInfo, this);
  status_timer_ = private_node.createTimer(ros::Duration(1.0), &DemNode::publishPeriodicStatus, this);
  ROS_INFO("dem_node: solver %s, scenario '%s'", demnerf::mechanics::solverName(solver_), config_.scenario.c_str());
}

void DemNode::onParticles(const sensor_msgs::PointCloud2ConstPtr& message) {
  try {
    demnerf::core::ParticleCloud cloud = particlesFromPointCloud2(*message);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      particles_ = std::move(cloud);
      ++particles_generation_;
    }
    requestSolve("new particles");
  } catch (const Error& error) {
    reportError(std::string("particles rejected: ") + error.what());
  }
}

void DemNode::onFixtures(const dem_nerf::FixtureArrayConstPtr& message) {
  try {
    dem_nerf::LoadCase load_case;
    load_case.fixtures = message->fixtures;
    const demnerf::core::Scenario scenario = scenarioFor(load_case);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_.fixtures = scenario.fixtures;
    }
    requestSolve("new fixtures");
  } catch (const Error& error) {
    reportError(std::string("fixtures rejected: ") + error.what());
  }
}

void DemNode::onWrench(const geometry_msgs::WrenchStampedConstPtr& message) {
  try {
    const auto& w = message->wrench;
    const Eigen::Vector3d force(w.force.x, w.force.y, w.force.z), torque(w.torque.x, w.torque.y, w.torque.z);
    if (!force.allFinite() || !torque.allFinite()) throw Error("it holds NaN or Inf");
    std::string why;
    if (!tf_buffer_.canTransform(config_.particles_frame, message->header.frame_id, message->header.stamp,
                                 ros::Duration(config_.tf_timeout), &why)) {
      throw Error("no tf from '" + config_.particles_frame + "' to the wrench frame '" + message->header.frame_id +
                  "': " + why);
    }
    const Eigen::Isometry3d pose = tf2::transformToEigen(
        tf_buffer_.lookupTransform(config_.particles_frame, message->header.frame_id, message->header.stamp));
    // The wrench acts at its frame's origin on the surface particles within ~contact_radius.
    demnerf::core::Load load;
    load.name = "wrench in " + message->header.frame_id;
    load.region.type = demnerf::core::Region::Type::kSphere;
    load.region.center = pose.translation();
    load.region.radius = config_.contact_radius;
    load.force = pose.linear() * force;
    load.torque = pose.linear() * torque;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_.loads = {load};
    }
    requestSolve("wrench");
  } catch (const Error& error) {
    reportError(std::string("wrench rejected: ") + error.what());
  }
}

void DemNode::onLoadCase(const dem_nerf::LoadCaseConstPtr& message) {
  try {
    const demnerf::core::Scenario scenario = scenarioFor(*message);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      scenario_ = scenario;
    }
    requestSolve("load case");
  } catch (const Error& error) {
    reportError(std::string("load case rejected: ") + error.what());
  }
}

void DemNode::onModel(const dem_nerf::ModelInfoConstPtr& message) {
  std::optional<demnerf::core::ResultField> result;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    model_info_path_ = message->model_path;
    model_info_frame_ = message->header.frame_id;
    result = last_result_;
  }
  if (result) requestRender(*result);  // a newer model changes how the current result looks
}

void DemNode::onRenderCameraInfo(const sensor_msgs::CameraInfoConstPtr& message) {
  try {
    const demnerf::core::PinholeCamera camera = fromCameraInfo(*message);
    std::lock_guard<std::mutex> lock(mutex_);
    render_camera_ = camera;
  } catch (const Error& error) {
    reportError(std::string("render camera_info rejected: ") + error.what());
  }
}

void DemNode::onRenderSubscriber(const image_transport::SingleSubscriberPublisher&) {
  std::optional<demnerf::core::ResultField> result;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    result = last_result_;
  }
  if (result) requestRender(*result);
}

void DemNode::requestRender(const demnerf::core::ResultField& result) {
  if (config_.render_frame.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_result_ = result;
  }
  // Compute only when someone listens (image_pipeline style): a render costs about a second.
  if (rendered_publisher_.getNumSubscribers() == 0) return;
  RenderJob job;
  job.result = result;
  job.stamp = ros::Time::now();
  render_worker_->submit(std::move(job));
}

void DemNode::runRender(const RenderJob& job) {
  if (rendered_publisher_.getNumSubscribers() == 0) return;  // the listener left while this waited
  try {
    std::string model_path, model_frame;
    std::optional<demnerf::core::PinholeCamera> camera;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      model_path = model_info_path_.empty() ? config_.model_path : model_info_path_;
      model_frame = model_info_frame_;
      camera = render_camera_;
    }
    if (model_path.empty()) {
      throw Error("no NeRF model to render with: no ModelInfo on 'model' yet and no ~model_path set");
    }
    if (!model_frame.empty() && model_frame != config_.particles_frame) {
      throw Error("the NeRF model is in frame '" + model_frame + "' but ~particles_frame is '" +
                  config_.particles_frame + "'");
    }
    view_.useModel(model_path);
    if (!camera) camera = cameraFromFieldOfView(config_.render_width, config_.render_height, config_.render_fov);
    std::string why;
    if (!tf_buffer_.canTransform(config_.particles_frame, config_.render_frame, ros::Time(0),
                                 ros::Duration(config_.tf_timeout), &why)) {
      throw Error("no tf from '" + config_.particles_frame + "' to ~render_frame '" + config_.render_frame +
                  "': " + why);
    }
    const Eigen::Isometry3d world_from_camera = tf2::transformToEigen(
        tf_buffer_.lookupTransform(config_.particles_frame, config_.render_frame, ros::Time(0)));
    const ros::WallTime start = ros::WallTime::now();
    const cv::Mat rgba = view_.render(job.result, *camera, world_from_camera);
    const double seconds = (ros::WallTime::now() - start).toSec();
    std_msgs::Header header;
    header.stamp = job.stamp;
    header.frame_id = config_.render_frame;
    rendered_publisher_.publish(cv_bridge::CvImage(header, sensor_msgs::image_encodings::RGBA8, rgba).toImageMsg());
    std::ostringstream text;
    text.precision(3);
    text << camera->width << "x" << camera->height << " in " << seconds << " s";
    std::lock_guard<std::mutex> lock(mutex_);
    ++renders_;
    last_render_ = text.str();
  } catch (const std::exception& error) {
    // Bad model files, tf errors and torch errors alike: report, keep the node and the last image.
    reportError(std::string("~rendered not updated: ") + error.what());
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
  const Eigen::Vector3d body_force(load_case.body_force.x, load_case.body_force.y, load_case.body_force.z);
  if (!body_force.isZero()) scenario.body_force = body_force;
  scenario.validate("load case");
  for (const auto& fixture : scenario.fixtures) {
    demnerf::geometry::selectParticles(*particles_, fixture.region, "fixture '" + fixture.name + "'");
  }
  return scenario;
}

void DemNode::requestSolve(const std::string& cause) {
  SolveJob job;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!particles_ || !scenario_loaded_ || scenario_.loads.empty()) return;
    job.cloud = *particles_;
    job.cloud_generation = particles_generation_;
    job.scenario = scenario_;
    stage_ = "solving";
  }
  job.cause = cause;
  worker_->submit(std::move(job));
}

demnerf::mechanics::SimulationOutcome DemNode::solveWithSession(const SolveJob& job, std::string& how) {
  if (!dem_session_) dem_session_ = std::make_unique<demnerf::mechanics::DemSession>(config_.simulateOptions().dem);
  if (session_generation_ != job.cloud_generation) {
    dem_session_->setParticles(job.cloud);
    session_generation_ = job.cloud_generation;
  }
  const demnerf::mechanics::DemSessionAnswer answer = dem_session_->answer(job.scenario);
  how = answer.mode == "instant" ? "instant (parametric, load x" + std::to_string(answer.load_scale) + ")"
                                 : answer.mode + " DEM";
  return answer.outcome;
}

void DemNode::runSolve(const SolveJob& job) {
  try {
    // The DEM lives across solves (warm starts; with ~parametric, scaled loads need no training);
    // the baselines solve from scratch.
    std::string how;
    const demnerf::mechanics::SimulationOutcome outcome =
        solver_ == demnerf::mechanics::SolverChoice::kDem
            ? solveWithSession(job, how)
            : demnerf::mechanics::simulate(job.cloud, job.scenario, solver_, config_.simulateOptions());
    publishResult(outcome, job.scenario);
    const std::string figures = describe(outcome) + (how.empty() ? "" : ", " + how);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage_ = "solved";
      last_figures_ = figures;
    }
    publishStatus("solved", job.cause + ": " + figures);
  } catch (const Error& error) {
    // The last good solution stays published; the error says why this one failed.
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage_ = "error";
    }
    reportError(job.cause + " not solved: " + error.what());
  }
}

void DemNode::publishResult(const demnerf::mechanics::SimulationOutcome& outcome,
                            const demnerf::core::Scenario& scenario) {
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = config_.particles_frame;
  displaced_publisher_.publish(toPointCloud2(outcome.field, header, /*displaced_positions=*/true));
  visualization_msgs::MarkerArray markers;
  double largest = 0.0;
  for (const auto& load : scenario.loads) largest = std::max(largest, load.force.norm());
  int id = 0;
  for (const auto& fixture : scenario.fixtures) {
    markers.markers.push_back(regionMarker(fixture.region, config_.particles_frame, id++, 0.2f, 0.4f, 1.0f));
  }
  for (const auto& load : scenario.loads) {
    markers.markers.push_back(forceArrow(load, config_.particles_frame, id++, largest > 0 ? 0.05 / largest : 0.0));
  }
  markers_publisher_.publish(markers);
  requestRender(outcome.field);
}

bool DemNode::solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response) {
  try {
    demnerf::core::ParticleCloud cloud;
    const demnerf::core::Scenario scenario = scenarioFor(request.load_case);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      cloud = *particles_;
    }
    const demnerf::mechanics::SimulationOutcome outcome =
        demnerf::mechanics::simulate(cloud, scenario, solver_, config_.simulateOptions());
    std_msgs::Header header = request.load_case.header;
    header.frame_id = config_.particles_frame;
    header.stamp = ros::Time::now();
    response.displaced = toPointCloud2(outcome.field, header, /*displaced_positions=*/false);
    response.seconds = outcome.seconds;
    response.energy = outcome.energy;
    response.max_displacement = outcome.max_displacement;
    response.ok = true;
    response.message = describe(outcome);
    publishResult(outcome, scenario);
  } catch (const Error& error) {
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
  std::string stage, message;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stage = stage_;
    message = (particles_ ? std::to_string(particles_->size()) + " particles" : std::string("no particles yet")) +
              (last_figures_.empty() ? "" : "; last solve: " + last_figures_) +
              (config_.render_frame.empty() ? ""
                                            : "; " + std::to_string(renders_) + " renders" +
                                                  (last_render_.empty() ? "" : " (last " + last_render_ + ")")) +
              (last_error_.empty() ? "" : "; last error: " + last_error_);
  }
  publishStatus(stage, message);
}

}  // namespace dem_nerf
