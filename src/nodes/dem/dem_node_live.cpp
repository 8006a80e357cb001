// dem_node's live settings (dynamic_reconfigure) and interactive push markers: their start and
// the hooks through which they change the current load case. Apart from dem_node.cpp, which wires
// the topics and the solve worker.

#include <algorithm>
#include <chrono>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/regions.hpp"
#include "nodes/dem/dem_node.hpp"
#include "ros_params/parameters.hpp"

namespace dem_nerf {

void DemNode::startLiveSettings(const ros::NodeHandle& private_node) {
  demnerf::core::Material material;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (scenario_loaded_) material = scenario_.material;
    solve_time_limit_ = config_.solver_options.control.time_limit;
  }
  const LiveSolveSettings initial = initialLiveSettings(demnerf::mechanics::parseSolverChoice(config_.solver),
                                                        config_.solver_options, material);
  live_ = std::make_unique<LiveSettings>(
      private_node, initial, [this](const std::string& what) { requestSolve("live settings (" + what + ")"); },
      [this](const std::string& why) { reportError("live_settings", why); });
  try {
    readNumber(private_node, "patch_basis_force_range", patch_basis_config_.force_range, 0.0);
    readNumber(private_node, "patch_basis_torque_range", patch_basis_config_.torque_range, 0.0);
  } catch (const std::exception& error) {
    patch_basis_config_.force_range = 0.0;
    reportError("patch_basis", std::string("no patch basis: ") + error.what());
  }
  try {
    if (!InteractivePush::enabled(private_node)) return;
    InteractivePush::Hooks hooks;
    hooks.push = [this](const demnerf::core::Load& load) { onPushLoad(load); };
    hooks.fixture = [this](const Eigen::Vector3d& center, const Eigen::Vector3d& size) { onFixtureBox(center, size); };
    hooks.refuse = [this](const std::string& cause, const std::string& message) { reportError(cause, message); };
    push_ = std::make_unique<InteractivePush>(private_node, config_.particles_frame, config_.contact_radius,
                                              InteractivePush::readConfig(private_node), hooks);
  } catch (const std::exception& error) {  // a bad ~push_* parameter: the node runs without markers
    reportError("interactive", std::string("no interactive push: ") + error.what());
  }
}

void DemNode::onPushLoad(const demnerf::core::Load& load) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    scenario_.loads = {load};
  }
  requestSolve("push");
}

void DemNode::onFixtureBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!particles_) throw demnerf::core::Error("no particle cloud yet");
    demnerf::core::Scenario scenario = scenario_;
    placeFixtureBox(scenario, center, size);
    // A box beside the body would leave it free: refused (the message says where it is).
    demnerf::geometry::selectParticles(*particles_, scenario.fixtures.front().region, "the fixture box");
    scenario_.fixtures = scenario.fixtures;
  }
  requestSolve("fixture box");
}

std::optional<demnerf::mechanics::SimulationOutcome> DemNode::solveWithPatchBasis(
    const SolveJob& job, const demnerf::mechanics::SolveControl& control, SolveReport& report) {
  // The basis superposes grid-Newton solves of one wrench on one patch.
  const demnerf::mechanics::DemConfig& dem = job.settings.options.dem;
  if (!(patch_basis_config_.force_range > 0.0) || dem.parametric.enabled || job.scenario.loads.size() != 1) return std::nullopt;
  const auto start = std::chrono::steady_clock::now();
  std::ostringstream text;
  text.precision(3);
  if (!patch_basis_ || patch_basis_cloud_ != job.cloud_generation ||
      patch_basis_model_ != job.settings.model_generation || !patch_basis_->answersFor(job.scenario)) {
    patch_basis_.reset();
    auto basis = std::make_unique<demnerf::mechanics::PatchResponse>(
        job.cloud, job.scenario, job.scenario.loads.front().region, dem, patch_basis_config_);
    // Newer drags must not cancel the preparation (it would never finish while the user drags):
    // only a shutdown stops it.
    demnerf::mechanics::SolveControl preparation = control;
    preparation.cancel = &shutting_down_;
    basis->prepare(preparation);
    patch_basis_ = std::move(basis);
    patch_basis_cloud_ = job.cloud_generation;
    patch_basis_model_ = job.settings.model_generation;
    text << "patch basis prepared (" << patch_basis_->preparationSolves() << " DEM solves, "
         << patch_basis_->preparationSeconds() << " s), then ";
    report.figures.basis_prepared = true;
    report.figures.basis_solves = static_cast<std::uint32_t>(patch_basis_->preparationSolves());
    report.figures.basis_seconds = patch_basis_->preparationSeconds();
  }
  const demnerf::core::Load& load = job.scenario.loads.front();
  const demnerf::mechanics::PatchAnswer answer = patch_basis_->answer(load.force, load.torque, control);
  if (answer.path == "basis") {
    text << "instant (patch basis, " << answer.seconds * 1000.0 << " ms)";
    report.figures.answered_by = dem_nerf::SolveAnswer::PATCH_BASIS;
  } else {
    text << "full DEM solve, warm-started (wrench outside the patch basis range)";
    report.figures.answered_by = dem_nerf::SolveAnswer::PATCH_BASIS_OUTSIDE;
  }
  report.how = text.str();
  demnerf::mechanics::SimulationOutcome outcome;
  outcome.field = answer.field;
  outcome.energy = answer.energy;
  for (const auto& u : outcome.field.displacements) outcome.max_displacement = std::max(outcome.max_displacement, u.norm());
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return outcome;
}

}  // namespace dem_nerf
