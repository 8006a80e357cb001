// dem_node's solve side: every request (topics and ~solve alike) becomes a job on the one
// latest-wins worker; the DEM lives across solves in a DemSession (warm starts, parametric answers).
#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "conversions/marker_conversions.hpp"
#include "nodes/dem/dem_node.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

std::string describe(const demnerf::mechanics::SimulationOutcome& outcome) {
  std::ostringstream text;
  text.precision(4);
  text << outcome.field.size() << " particles, max displacement " << outcome.max_displacement * 1000.0 << " mm, ";
  // A patch-basis answer superposes solves and has no energy of its own (NaN).
  if (std::isfinite(outcome.energy))
    text << "energy " << outcome.energy << " J, ";
  else
    text << "energy not computed, ";
  text << outcome.seconds << " s";
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

demnerf::mechanics::SimulationOutcome zeroOutcome(const demnerf::core::ParticleCloud& cloud) {
  demnerf::mechanics::SimulationOutcome outcome;
  outcome.field.resize(cloud.size());
  outcome.field.positions = cloud.positions;
  return outcome;
}

}  // namespace

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
                                                               SolveReport& report) {
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
  const bool instant = answer.mode == "instant";
  report.how = instant ? "instant (parametric, load x" + std::to_string(answer.load_scale) + ")" : answer.mode + " DEM";
  report.figures.answered_by = instant                ? dem_nerf::SolveAnswer::INSTANT_PARAMETRIC
                               : answer.mode == "warm" ? dem_nerf::SolveAnswer::WARM
                                                       : dem_nerf::SolveAnswer::COLD;
  if (instant) report.figures.load_scale = answer.load_scale;
  if (!answer.outcome.coarse_grid.empty()) {
    report.how += " (coarse particles: a stiff answer)";
    ROS_WARN_THROTTLE(10.0, "dem_node: %s", answer.outcome.coarse_grid.c_str());
  }
  if (!answer.warm_failure.empty()) {
    report.how += " (the warm start failed its check; a new network answered)";
    ROS_WARN_THROTTLE(10.0, "dem_node: warm start refused, solved again cold: %s", answer.warm_failure.c_str());
  }
  if (!answer.unverified.empty()) {
    report.how += " (not verified as an equilibrium)";
    ROS_WARN_THROTTLE(10.0, "dem_node: parametric DEM answer not verified: %s", answer.unverified.c_str());
  }
  return answer.outcome;
}

demnerf::mechanics::SimulationOutcome DemNode::solveJob(const SolveJob& job, SolveReport& report) {
  // Degenerate set-ups and bad regions are refused here, before any solver factorises anything.
  demnerf::mechanics::validateProblem(job.scenario, job.cloud);
  if (loadFree(job.scenario)) {
    report.how = "no load: zero displacement";
    report.figures.answered_by = dem_nerf::SolveAnswer::NO_LOAD;
    return zeroOutcome(job.cloud);
  }
  demnerf::mechanics::SimulateOptions options = job.settings.options;
  options.control.cancel = &cancel_;
  options.control.progress = [this](const demnerf::mechanics::SolveProgress& progress) {
    std::lock_guard<std::mutex> lock(mutex_);
    solve_progress_ = progress;
  };
  // The DEM lives across solves (warm starts; with ~dem/parametric/enabled, scaled loads need no training);
  // the baselines solve from scratch.
  if (job.settings.solver != demnerf::mechanics::SolverChoice::kDem) {
    report.figures.answered_by = dem_nerf::SolveAnswer::BASELINE;
    return demnerf::mechanics::simulate(job.cloud, job.scenario, job.settings.solver, options);
  }
  if (auto outcome = solveWithPatchBasis(job, options.control, report)) return *outcome;
  return solveWithSession(job, options.control, report);
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
    SolveReport report;
    const demnerf::mechanics::SimulationOutcome outcome = solveJob(job, report);
    publishResult(outcome, job.scenario);
    const SolutionExport::Report exported = export_.write(job.cloud, outcome);  // never throws
    const std::string figures = describe(outcome) + (report.how.empty() ? "" : ", " + report.how) + exported.note;
    dem_nerf::SolveAnswer& answer = report.figures;
    answer.cause = job.cause;
    answer.solver = demnerf::mechanics::solverName(job.settings.solver);
    answer.particles = static_cast<std::uint32_t>(job.cloud.size());
    answer.seconds = outcome.seconds;
    answer.energy = outcome.energy;
    answer.max_displacement = outcome.max_displacement;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage_ = "solved";
      last_figures_ = figures;
      answer.sequence = last_answer_.sequence + 1;
      last_answer_ = answer;
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

}  // namespace dem_nerf
