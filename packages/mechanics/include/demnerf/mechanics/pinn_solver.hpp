#pragma once
// The strong-form PINN baseline (the paper's "DEM vs PINN" section): an MLP u(X) trained on the
// equilibrium residual Div P + f_b = 0 (second derivatives), the traction residual P N - t and
// the displacement residual u - u_bar, weighted W_R, W_t, W_u. LibTorch; no torch in this header.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/solve_control.hpp"

namespace demnerf::mechanics {

/// The strong-form PINN baseline's settings; why each default is what it is: docs/dem_config.md
/// ("FemConfig and PinnConfig").
struct PinnConfig {
  int width = 64;                    ///< hidden units per layer
  int depth = 3;                     ///< hidden layers
  std::string activation = "tanh";   ///< tanh | sin | softplus (smooth: the loss needs Hessians)
  /// Loss weights; every residual is made dimensionless by the expected stress mu * strain.
  double weight_residual = 1.0;      ///< W_R on MSE_R, |Div P + f_b| L / (mu strain)
  double weight_traction = 10.0;     ///< W_t on MSE_t, |P N - t| / (mu strain)
  double weight_displacement = 100.0;  ///< W_u on MSE_u, |u - u_bar| / (strain L)
  int adam_iterations = 1000;        ///< per load step
  int residual_batch = 1024;         ///< residual particles per Adam step, drawn afresh (0: all)
  bool jitter = true;                ///< residual points move within their particle's cell every Adam step
  double adam_learning_rate = 2e-3;  ///< initial rate
  double adam_final_rate_ratio = 0.02;  ///< the rate decays exponentially to rate x this over a step
  int rescale_every = 25;            ///< output amplitude line search every N steps of the first load step (0: never)
  int rescale_until = 200;           ///< ...during its first N steps
  /// m the network's unit output stands for (also the residuals' normalisation); 0: estimated as
  /// traction / E x size, then refitted as above.
  double displacement_scale = 0.0;
  int lbfgs_iterations = 200;        ///< L-BFGS polish per load step after Adam (0: off)
  int lbfgs_history = 50;
  int load_steps = 1;                ///< 0: the scenario's
  int max_halvings = 4;              ///< load-step halvings after an inverted or NaN solve
  int threads = 0;                   ///< torch threads; 0 = 1 below 50k particles, all cores above
  int seed = 1;
  bool double_precision = false;     ///< float32 by default, as the DEM
  bool verbose = false;
};

struct PinnReport {
  double seconds = 0.0;
  double loss = 0.0;                 ///< weighted total at full load
  double residual_mse = 0.0;         ///< MSE_R (dimensionless, unweighted)
  double traction_mse = 0.0;         ///< MSE_t
  double displacement_mse = 0.0;     ///< MSE_u
  double energy = 0.0;               ///< total potential energy of the trained field (J), for comparison
  double min_J = 0.0;                ///< smallest det F over the particles
  int iterations = 0;                ///< optimiser iterations over all load steps
  int load_steps = 0;                ///< load steps taken, halvings included
  double output_scale = 0.0;         ///< displacement scale of the network output (m)
};

class PinnSolver {
 public:
  /// Validates scenario, particles and config (core::Error before any training); builds the net.
  PinnSolver(core::ParticleCloud cloud, const core::Scenario& scenario, PinnConfig config = {});
  ~PinnSolver();
  PinnSolver(PinnSolver&&) noexcept;

  /// Trains over the load steps, warm-started from the current network, with no time limit and
  /// no progress reports. Throws SolveError{kInverted} (a core::Error) when a step inverts
  /// particles or turns NaN even with the smallest step (the network then keeps the last good
  /// state).
  PinnReport solve();
  /// The same under a time budget, progress sink and cancel flag: control.check() at every Adam
  /// iteration and L-BFGS evaluation (SolveError kTimeLimit / kCancelled; the network goes back
  /// to the last completed load step), and a report (phase adam / lbfgs, load fraction,
  /// iteration, energy of the current field) at most once per progress interval.
  PinnReport solve(const SolveControl& control);
  /// The same on a clock the caller started.
  PinnReport solve(SolveClock& clock);
  /// Displacement at arbitrary points.
  std::vector<Eigen::Vector3d> predict(const std::vector<Eigen::Vector3d>& points) const;
  /// Rest positions, displacement and von Mises stress at the particles, in their order.
  core::ResultField result() const;
  /// Check of the hand-written second-order terms: the largest difference between the Div P the
  /// loss uses (forward-mode Hessian, closed-form dP/dF) and reverse-mode autograd of P(F(X)) at
  /// up to 64 residual particles, relative to the largest |Div P| there.
  double divergenceSelfCheck() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::mechanics
