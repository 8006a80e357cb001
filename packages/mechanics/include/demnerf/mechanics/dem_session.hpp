#pragma once
// A DEM that lives across load changes, as dem_node needs it: the network trained on one load
// case answers the next one warm-started, and in parametric mode a load case that only scales
// the trained one (same regions, forces, torques, body force and prescribed displacements times
// one factor s inside the trained range) is answered at once, without any training. In
// parametric mode only a load beyond the range in the trained direction (s > 0) is warm-started;
// any other is trained on a new network, a better start than the old load's field.

#include <memory>
#include <optional>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/solve_control.hpp"

namespace demnerf::mechanics {

/// How an answer was obtained: "instant" (parametric prediction, no training), "warm" (trained
/// from the previous network) or "cold" (a new network: the first answer, the one after a failed
/// solve or new particles, and in parametric mode a load that is no positive scaling of the trained one).
struct DemSessionAnswer {
  SimulationOutcome outcome;
  std::string mode;
  double load_scale = 1.0;  ///< instant answers: the factor s relative to the trained load case
  /// Parametric mode: why the trained answer failed its equilibrium check (DemReport::unverified);
  /// instant answers scale that training and inherit it.
  std::string unverified;
  /// Why the warm start failed, when a new network then answered (mode "cold"); empty otherwise.
  std::string warm_failure;
};

/// The factor s with `scaled` = s x `reference` in every load, body force and prescribed
/// displacement (regions, masks and material equal), or nothing. Tolerance relative to the
/// reference's size.
std::optional<double> loadScaleBetween(const core::Scenario& reference, const core::Scenario& scaled,
                                       double tolerance = 1e-6);

class DemSession {
 public:
  explicit DemSession(DemConfig config);

  /// New particles: the next answer trains a new network.
  void setParticles(core::ParticleCloud cloud);
  bool hasParticles() const { return cloud_.has_value(); }
  /// Solves the scenario on the current particles (core::Error when there are none, for bad
  /// input, or a failed solve; after a failed solve the next answer starts cold). A warm start
  /// that ends in no equilibrium (SolveFailure kNotConverged or kInverted) is tried once more on
  /// a new network within the rest of the budget (DemSessionAnswer::warm_failure says so).
  DemSessionAnswer answer(const core::Scenario& scenario);
  /// The same within a time budget, with progress and a cancel flag (mechanics::SolveError then).
  DemSessionAnswer answer(const core::Scenario& scenario, const SolveControl& control);

 private:
  void train(const core::Scenario& scenario, const SolveControl& control, DemSessionAnswer& answer);

  DemConfig config_;
  std::optional<core::ParticleCloud> cloud_;
  std::unique_ptr<DemSolver> solver_;
  core::Scenario trained_;  ///< the load case the network was trained for
  std::string unverified_;  ///< its training's failed equilibrium check (parametric), if any
  std::string coarse_grid_;  ///< its grid too coarse for the body (DemReport::coarse_grid), if so
};

}  // namespace demnerf::mechanics
