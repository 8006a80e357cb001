#pragma once
// The Deep Energy Method: an MLP displacement field u(X) trained by minimising the total
// potential energy of a particle-discretised Neo-Hookean body (LibTorch; no torch in this header).

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

struct DemConfig {
  int width = 64;                      ///< hidden units per layer
  int depth = 3;                       ///< hidden layers
  std::string activation = "tanh";     ///< tanh | sigmoid | softplus | sin
  /// kExact: u = g + D z (fixtures hold by construction). kPenalty: the paper's W_u * MSE_u.
  enum class Boundary { kExact, kPenalty };
  Boundary boundary = Boundary::kExact;
  double penalty_weight = 1e4;         ///< W_u (on MSE_u / L^2, with Pi / (mu V))
  int adam_iterations = 1500;          ///< per load step; the last third at a 10x smaller rate
  double adam_learning_rate = 2e-3;
  /// Adam samples each interior particle's quadrature point at random within its cell.
  bool jitter = true;
  /// L-BFGS polish per load step on the fixed particles (0: off). A deterministic optimiser can
  /// find displacement ramps hidden between sample points, so it is off by default.
  int lbfgs_iterations = 0;
  int lbfgs_history = 50;
  double tolerance = 1e-10;            ///< L-BFGS stops when the loss changes less than this
  int max_halvings = 4;                ///< load-step halvings after an inverted or NaN solve
  int threads = 0;                     ///< torch threads; 0 = all cores
  int seed = 1;
  bool double_precision = true;
  bool verbose = false;
};

struct DemReport {
  double seconds = 0.0;
  double energy = 0.0;        ///< total potential energy at full load (J)
  double min_J = 0.0;         ///< smallest det F over the particles
  int iterations = 0;         ///< optimiser iterations over all load steps
  int load_steps = 0;         ///< load steps taken, halvings included
};

class DemSolver {
 public:
  /// Validates scenario and particles (core::Error before any training) and builds the network.
  DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config = {});
  ~DemSolver();
  DemSolver(DemSolver&&) noexcept;

  /// Trains over the scenario's load steps, warm-started from the current network (a second
  /// call after changing nothing converges at once). Throws core::Error when the solve inverts
  /// particles or diverges even with the smallest load step; the network then keeps the last good
  /// state.
  DemReport solve();
  /// Replaces the scenario's loads and fixtures (same material) for a warm-started re-solve.
  void setScenario(const core::Scenario& scenario);
  /// Displacement at arbitrary points.
  std::vector<Eigen::Vector3d> predict(const std::vector<Eigen::Vector3d>& points) const;
  /// Rest positions, displacement and von Mises stress at the particles, in their order.
  core::ResultField result() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::mechanics
