#pragma once
// dem_node's live settings as plain values (no ROS): what cfg/DemNodeLive.cfg lets a user change
// while the node runs, how they are checked, and how they enter a solve. The dynamic_reconfigure
// server around them is live_settings.hpp.

#include <cstdint>
#include <string>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/simulate.hpp"

namespace dem_nerf {

/// The fields of cfg/DemNodeLive.cfg.
struct LiveValues {
  double youngs_modulus = 0.0;  ///< Pa
  double poisson_ratio = 0.0;
  std::string solver;           ///< dem | fem | pinn
  double dem_grid_spacings = 0.0;
  int fem_order = 1;
  double solve_time_limit = 0.0;  ///< s (0: none)
  double load_scale = 1.0;        ///< factor on the current load's forces and torques

  bool operator==(const LiveValues& other) const;
  bool operator!=(const LiveValues& other) const { return !(*this == other); }
};

/// What a solve takes from the live settings. A job carries its own copy, so the solve worker
/// never reads settings that a reconfigure call is changing.
struct LiveSolveSettings {
  demnerf::mechanics::SolverChoice solver = demnerf::mechanics::SolverChoice::kDem;
  demnerf::mechanics::SimulateOptions options;
  double youngs_modulus = 1e6;
  double poisson_ratio = 0.3;
  double load_scale = 1.0;
  /// Changes whenever the material or the DEM's settings change: a DEM kept across solves (warm
  /// starts, parametric answers) was trained for the old ones and must be rebuilt.
  std::uint64_t model_generation = 0;

  /// The scenario with this material; with scale_loads also its forces and torques times
  /// load_scale (the current load of the topics; a ~solve request's load is taken as given).
  void applyTo(demnerf::core::Scenario& scenario, bool scale_loads) const;
};

/// The settings a node starts with: its solver options and solver, the scenario's material.
LiveSolveSettings initialLiveSettings(demnerf::mechanics::SolverChoice solver,
                                      const demnerf::mechanics::SimulateOptions& options,
                                      const demnerf::core::Material& material);

/// The values a reconfigure client sees for these settings.
LiveValues liveValuesOf(const LiveSolveSettings& settings);

/// `current` with `values` applied. Throws demnerf::core::Error naming the first bad value (and
/// what it must be); `current` then stays as it is.
LiveSolveSettings withLiveValues(const LiveSolveSettings& current, const LiveValues& values);

/// "youngs_modulus 1e+06 -> 5e+05, load_scale 1 -> 2": what changed, for ~status.
std::string describeChange(const LiveValues& before, const LiveValues& after);

}  // namespace dem_nerf
