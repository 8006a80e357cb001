// dem_node's live settings (dynamic_reconfigure) and interactive push markers: their start and
// the hooks through which they change the current load case. Apart from dem_node.cpp, which wires
// the topics and the solve worker.

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/regions.hpp"
#include "nodes/dem/dem_node.hpp"

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

}  // namespace dem_nerf
