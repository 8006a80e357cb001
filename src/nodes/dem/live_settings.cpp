#include "nodes/dem/live_settings.hpp"

namespace dem_nerf {
namespace {

LiveValues fromConfig(const DemNodeLiveConfig& config) {
  LiveValues values;
  values.youngs_modulus = config.youngs_modulus;
  values.poisson_ratio = config.poisson_ratio;
  values.solver = config.solver;
  values.dem_grid_spacings = config.dem_grid_spacings;
  values.fem_order = config.fem_order;
  values.solve_time_limit = config.solve_time_limit;
  values.load_scale = config.load_scale;
  return values;
}

void toConfig(const LiveValues& values, DemNodeLiveConfig& config) {
  config.youngs_modulus = values.youngs_modulus;
  config.poisson_ratio = values.poisson_ratio;
  config.solver = values.solver;
  config.dem_grid_spacings = values.dem_grid_spacings;
  config.fem_order = values.fem_order;
  config.solve_time_limit = values.solve_time_limit;
  config.load_scale = values.load_scale;
}

}  // namespace

LiveSettings::LiveSettings(const ros::NodeHandle& private_node, const LiveSolveSettings& initial,
                           std::function<void(const std::string&)> changed,
                           std::function<void(const std::string&)> refused)
    : settings_(initial), changed_(std::move(changed)), refused_(std::move(refused)) {
  server_ = std::make_unique<dynamic_reconfigure::Server<DemNodeLiveConfig>>(server_mutex_, private_node);
  // The server starts from the .cfg defaults and any parameters of the same names; the values in
  // force are the node's (scenario material, solver options), so those are what clients see.
  DemNodeLiveConfig config;
  server_->getConfigDefault(config);
  toConfig(liveValuesOf(initial), config);
  server_->updateConfig(config);
  // setCallback calls back at once with the values just set: nothing changed then, no solve.
  server_->setCallback([this](DemNodeLiveConfig& next, std::uint32_t level) { onReconfigure(next, level); });
}

LiveSolveSettings LiveSettings::current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_;
}

void LiveSettings::onReconfigure(DemNodeLiveConfig& config, std::uint32_t) {
  std::string what, why;
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    const LiveValues before = liveValuesOf(settings_), requested = fromConfig(config);
    if (requested == before) return;
    try {
      settings_ = withLiveValues(settings_, requested);
      what = describeChange(before, liveValuesOf(settings_));
    } catch (const std::exception& error) {
      why = std::string("live settings refused (the values in force stay): ") + error.what();
    }
    // The client is told the values in force: the refused ones go back in its GUI.
    toConfig(liveValuesOf(settings_), config);
  } catch (const std::exception& error) {
    why = std::string("live settings: ") + error.what();
  }
  try {
    if (!why.empty()) refused_(why);
    else if (!what.empty()) changed_(what);
  } catch (const std::exception& error) {
    ROS_ERROR("dem_node: live settings: %s", error.what());
  }
}

}  // namespace dem_nerf
