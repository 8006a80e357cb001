#include "nodes/dem/dem_node.hpp"

#include <cv_bridge/cv_bridge.h>
#include <dem_nerf/TrainingStatus.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <sstream>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "conversions/region_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/geometry/regions.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "nodes/dem/result_markers.hpp"

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

// True when nothing drives a deformation: no force, torque, body force or prescribed displacement.
// The answer is then zero displacement (a zero wrench is a valid request, not a divergence).
bool loadFree(const demnerf::core::Scenario& scenario) {
  if (!scenario.body_force.isZero()) return false;
  for (const auto& load : scenario.loads)
    if (!load.force.isZero() || !load.torque.isZero()) return false;
  for (const auto& fixture : scenario.fixtures)
    if (!fixture.displacement.isZero()) return false;
  return true;
}

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

demnerf::mechanics::SimulationOutcome zeroOutcome(const demnerf::core::ParticleCloud& cloud) {
  demnerf::mechanics::SimulationOutcome outcome;
  outcome.field.resize(cloud.size());
  outcome.field.positions = cloud.positions;
  return outcome;
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

void DemNode::onModel(const dem_nerf::ModelInfoConstPtr& message) {
  try {
    std::optional<demnerf::core::ResultField> result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      model_info_path_ = message->model_path;
      model_info_frame_ = message->header.frame_id;
      result = last_result_;
    }
    if (result) requestRender(*result);  // a newer model changes how the current result looks
  } catch (const std::exception& error) {
    reportError("model", std::string("model info: ") + error.what());
  }
}

void DemNode::onRenderCameraInfo(const sensor_msgs::CameraInfoConstPtr& message) {
  try {
    const std::uint64_t pixels = std::uint64_t(message->width) * message->height;
    if (pixels > static_cast<std::uint64_t>(config_.max_render_pixels))
      throw Error(std::to_string(message->width) + "x" + std::to_string(message->height) +
                  " is more than ~max_render_pixels = " + std::to_string(config_.max_render_pixels) + " pixels");
    const demnerf::core::PinholeCamera camera = fromCameraInfo(*message);
    std::lock_guard<std::mutex> lock(mutex_);
    render_camera_ = camera;
  } catch (const std::exception& error) {
    reportError("render_camera_info", std::string("render camera_info rejected: ") + error.what());
  } catch (...) {
    reportError("render_camera_info", "render camera_info rejected: unknown exception");
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
    reportError("render", std::string("~rendered not updated: ") + error.what());
  } catch (...) {
    reportError("render", "~rendered not updated: unknown exception");
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
  job.settings = live_->current();
  job.settings.applyTo(job.scenario, /*scale_loads=*/true);
  job.cause = cause;
  submitSolve(std::move(job));
}

void DemNode::submitSolve(SolveJob job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A long solve yields to the newer request; quick ones finish (a wrench stream still gets
    // answers), and one a ~solve caller waits for is never cancelled for a topic message.
    const double running_for =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_started_).count();
    if (solve_running_ && !solve_has_reply_ && running_for >= config_.supersede_after) cancel_ = true;
  }
  const bool from_service = job.reply != nullptr;
  std::optional<SolveJob> replaced = worker_->exchange(std::move(job));
  if (!replaced || !replaced->reply) return;
  if (!from_service) {
    // A ~solve caller waits for the replaced job: it goes back, and the topic's job runs right
    // after it starts (a newer topic job replaces a deferred one: latest wins among them).
    std::optional<SolveJob> topic = worker_->exchange(std::move(*replaced));
    if (topic) {
      std::lock_guard<std::mutex> lock(mutex_);
      deferred_ = std::move(topic);
    }
    return;
  }
  rejections_.count("solve_superseded", "a waiting ~solve was superseded by a newer ~solve");
  replaced->reply->set_exception(
      std::make_exception_ptr(Error("superseded by a newer ~solve before it started; call again")));
}

demnerf::mechanics::SimulationOutcome DemNode::solveWithSession(const SolveJob& job,
                                                               const demnerf::mechanics::SolveControl& control,
                                                               std::string& how) {
  // Live settings that change the material or the DEM's settings need a new DEM.
  if (!dem_session_ || session_model_generation_ != job.settings.model_generation) {
    dem_session_ = std::make_unique<demnerf::mechanics::DemSession>(job.settings.options.dem);
    session_model_generation_ = job.settings.model_generation;
    session_generation_ = 0;  // no cloud yet
  }
  if (session_generation_ != job.cloud_generation) {
    dem_session_->setParticles(job.cloud);
    session_generation_ = job.cloud_generation;
  }
  const demnerf::mechanics::DemSessionAnswer answer = dem_session_->answer(job.scenario, control);
  how = answer.mode == "instant" ? "instant (parametric, load x" + std::to_string(answer.load_scale) + ")"
                                 : answer.mode + " DEM";
  return answer.outcome;
}

demnerf::mechanics::SimulationOutcome DemNode::solveJob(const SolveJob& job, std::string& how) {
  // Degenerate set-ups and bad regions are refused here, before any solver factorises anything.
  demnerf::mechanics::validateProblem(job.scenario, job.cloud);
  if (loadFree(job.scenario)) {
    how = "no load: zero displacement";
    return zeroOutcome(job.cloud);
  }
  demnerf::mechanics::SimulateOptions options = job.settings.options;
  options.control.cancel = &cancel_;
  options.control.progress = [this](const demnerf::mechanics::SolveProgress& progress) {
    std::lock_guard<std::mutex> lock(mutex_);
    solve_progress_ = progress;
  };
  // The DEM lives across solves (warm starts; with ~parametric, scaled loads need no training);
  // the baselines solve from scratch.
  if (job.settings.solver != demnerf::mechanics::SolverChoice::kDem)
    return demnerf::mechanics::simulate(job.cloud, job.scenario, job.settings.solver, options);
  if (auto outcome = solveWithPatchBasis(job, options.control, how)) return *outcome;
  return solveWithSession(job, options.control, how);
}

void DemNode::runSolve(const SolveJob& job) {
  std::optional<SolveJob> deferred;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    deferred = std::move(deferred_);
    deferred_.reset();
  }
  // A topic job that waited behind this ~solve queues now (unless a newer one is already there).
  if (deferred && !worker_->busyWithWaiting()) worker_->submit(std::move(*deferred));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    cancel_ = shutting_down_.load();
    solve_running_ = true;
    solve_has_reply_ = job.reply != nullptr;
    solve_started_ = std::chrono::steady_clock::now();
    solve_progress_ = {};
    solve_progress_.solver = demnerf::mechanics::solverName(job.settings.solver);
    solve_time_limit_ = job.settings.options.control.time_limit;
    solve_progress_.phase = "start";
  }
  std::exception_ptr failure;
  try {
    std::string how;
    const demnerf::mechanics::SimulationOutcome outcome = solveJob(job, how);
    publishResult(outcome, job.scenario);
    const SolutionExport::Report exported = export_.write(job.cloud, outcome);  // never throws
    const std::string figures = describe(outcome) + (how.empty() ? "" : ", " + how) + exported.note;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage_ = "solved";
      last_figures_ = figures;
      solve_running_ = false;
    }
    publishStatus("solved", job.cause + ": " + figures);
    if (!exported.error.empty()) reportError("export", exported.error);
    if (job.reply) job.reply->set_value(outcome);  // last: nothing after it can throw
    return;
  } catch (const demnerf::mechanics::SolveError& error) {
    failure = std::current_exception();  // only valid inside the handler
    reportSolveFailure(job, std::string("solve_") + demnerf::mechanics::solveFailureName(error.failure()), error.what());
  } catch (const Error& error) {
    failure = std::current_exception();
    reportSolveFailure(job, "solve_input", error.what());
  } catch (const std::exception& error) {  // torch's c10::Error (out of memory), bad_alloc, ...
    failure = std::current_exception();
    reportSolveFailure(job, "solve_internal", std::string("the solver failed: ") + error.what());
  } catch (...) {
    failure = std::current_exception();
    reportSolveFailure(job, "solve_internal", "the solver failed with an unknown exception");
  }
  if (job.reply) job.reply->set_exception(failure);
}

void DemNode::reportSolveFailure(const SolveJob& job, const std::string& cause, const std::string& message) {
  // The last good solution stays published; the error says why this one failed.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stage_ = "error";
    solve_running_ = false;
  }
  reportError(cause, job.cause + " not solved: " + message);
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

// The request goes through the worker like every other solve (never beside it), and this
// callback, on its own queue, waits for the answer.
bool DemNode::solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response) {
  bool submitted = false;  // from then on the worker counts a failure
  try {
    requireParticlesFrame(request.load_case.header.frame_id, "the load case");
    SolveJob job;
    job.scenario = scenarioFor(request.load_case);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job.cloud = *particles_;
      job.cloud_generation = particles_generation_;
      stage_ = "solving";
    }
    job.settings = live_->current();
    job.settings.applyTo(job.scenario, /*scale_loads=*/false);
    job.cause = "~solve";
    job.reply = std::make_shared<std::promise<demnerf::mechanics::SimulationOutcome>>();
    std::future<demnerf::mechanics::SimulationOutcome> answer = job.reply->get_future();
    submitSolve(std::move(job));
    submitted = true;
    while (answer.wait_for(std::chrono::milliseconds(100)) != std::future_status::ready) {
      if (shutting_down_ || ros::isShuttingDown()) {
        cancel_ = true;
        throw Error("dem_node is shutting down; the solve was cancelled");
      }
    }
    const demnerf::mechanics::SimulationOutcome outcome = answer.get();  // rethrows the solve's error
    std_msgs::Header header = request.load_case.header;
    header.frame_id = config_.particles_frame;
    header.stamp = ros::Time::now();
    response.displaced = toPointCloud2(outcome.field, header, /*displaced_positions=*/false);
    response.seconds = outcome.seconds;
    response.energy = outcome.energy;
    response.max_displacement = outcome.max_displacement;
    response.ok = true;
    response.message = describe(outcome);
  } catch (const std::exception& error) {
    response.ok = false;
    response.message = error.what();
    // Refusals before the job ran are counted here; the worker counted failed solves already.
    if (!submitted) reportError("solve_request", std::string("~solve: ") + error.what());
  } catch (...) {
    response.ok = false;
    response.message = "~solve failed with an unknown exception";
    reportError("solve_request", response.message);
  }
  return true;
}

void DemNode::reportError(const std::string& cause, const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = message;
  }
  rejections_.count(cause, message);
  publishStatus("error", message);
}

void DemNode::publishStatus(const std::string& stage, const std::string& message) {
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.stage = stage;
  status.message = message;
  status.rejections = rejections_.counts();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status.solve.running = solve_running_;
    status.solve.time_limit = solve_time_limit_;
    if (solve_running_) {
      status.solve.solver = solve_progress_.solver;
      status.solve.phase = solve_progress_.phase;
      status.solve.load_fraction = solve_progress_.load_fraction;
      status.solve.iteration = static_cast<std::uint32_t>(std::max(solve_progress_.iteration, 0));
      status.solve.energy = solve_progress_.energy;
      status.solve.residual = solve_progress_.residual;
      status.solve.elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_started_).count();
    }
  }
  status_publisher_.publish(status);
}

void DemNode::publishPeriodicStatus(const ros::TimerEvent&) {
  try {
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
      if (solve_running_) {
        std::ostringstream text;
        text.precision(3);
        text << "; solving (" << solve_progress_.phase << ", load " << solve_progress_.load_fraction << ", iteration "
             << solve_progress_.iteration << ", "
             << std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_started_).count() << " s of "
             << solve_time_limit_ << " s)";
        message += text.str();
      }
    }
    publishStatus(stage, message);
  } catch (const std::exception& error) {
    ROS_ERROR_THROTTLE(5.0, "dem_node: status not published: %s", error.what());
  }
}

}  // namespace dem_nerf
