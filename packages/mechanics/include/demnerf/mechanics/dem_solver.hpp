#pragma once
// The Deep Energy Method: an MLP displacement field u(X) trained by minimising the total
// potential energy of a particle-discretised Neo-Hookean body (LibTorch; no torch in this header).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/solve_control.hpp"

namespace demnerf::mechanics {

/// The defaults are the product's DEM: a feature grid sized from the body (grid_body_cells),
/// integrated by Gauss points in its cells wherever the particles say the body is (kCells, so the
/// sampler does not matter), with extended B-splines at cut cells, solved by Newton
/// (adam_iterations = 0); paperDemConfig() is the paper's MLP-only DEM. The grid sized in particle
/// spacings and integrated by the particles (grid_spacings, kParticles) is the earlier default,
/// right on lattice clouds only: docs/dem_feature_grid.md. `demnerf simulate` and dem_node start
/// from these (config/solvers.yaml lists every field).
struct DemConfig {
  int width = 64;                      ///< hidden units per layer
  int depth = 3;                       ///< hidden layers
  std::string activation = "tanh";     ///< tanh | sigmoid | softplus | sin
  /// kExact: u = g + D z (fixtures hold by construction). kPenalty: the paper's W_u * MSE_u.
  enum class Boundary { kExact, kPenalty };
  Boundary boundary = Boundary::kExact;
  double penalty_weight = 1e4;         ///< W_u (on MSE_u / L^2, with Pi / (mu V))
  /// Per load step, full batch (all particles every step). 0 by default: the feature grid's Newton
  /// solve is the training; paperDemConfig() (the MLP alone) takes 1500.
  int adam_iterations = 0;
  double adam_learning_rate = 1e-2;   ///< best of 2e-3 / 5e-3 / 1e-2 on the uniaxial cube
  /// The rate decays exponentially to adam_learning_rate * adam_final_rate_ratio over a load step.
  double adam_final_rate_ratio = 0.02;
  /// The network's output amplitude is refitted by a 1-D energy line search at these Adam
  /// iterations of the first load step (0: never). The a-priori displacement scale (traction /
  /// stiffness x size) can be 100x off for slender bodies (torsion), and Adam cannot grow the
  /// output layer 100x in a few hundred steps.
  int rescale_every = 25;
  int rescale_until = 200;
  /// Ritz-Newton on the output layer (exact boundary mode): before, every newton_every Adam
  /// iterations during (0: never), and after each load step's Adam run, the output layer is
  /// solved by Newton's method with the hidden layers frozen (output_layer_newton.hpp), and the
  /// amplitude line search (rescale_every) is skipped. With adam_iterations = 0 this is a pure
  /// Ritz solve in the network's basis: the uniaxial cube to 0.5 % in 0.01 s, and the fast
  /// re-solve for new loads (solveInBasis). Off by default: on the T-bar twist a random basis is
  /// too stiff (51 % error) and Adam steps after a Newton solve invert particles unless the rate is
  /// cut 100x (notes in README "Mechanics").
  bool output_newton = false;
  int newton_every = 0;
  int newton_iterations = 12;
  /// Feature grid (exact boundary mode, not parametric; 0: off): a B-spline grid
  /// (bspline_grid.hpp) with cells of this edge (m) whose coefficients C join the network's
  /// output, u = g + D o c (z(X) + N(X) C), like the multiresolution grids of an instant-NGP
  /// field. C is solved by Newton's method with the MLP frozen (grid_field_newton.hpp) before and
  /// after each load step's Adam run, and trained with the MLP by Adam in between. Local support is
  /// what the twist needs: the warping of a square section and the clamp's boundary layer (T-bar
  /// twist: 1.8 % in 3.9 s at 15 mm cells, where the MLP alone reaches 22 % in 20 s; README
  /// "Mechanics").
  double grid_cell = 0.0;
  /// With grid_cell 0: a grid of cells this many particle spacings wide (the cube root of the 90th
  /// percentile of the particle volumes; 2 suits the particle quadrature). 0 (default): the grid
  /// follows grid_body_cells; no grid at all (the MLP alone) when that is 0 too.
  double grid_spacings = 0.0;
  int grid_degree = 2;  ///< 1 (trilinear), 2 (C1 quadratic) or 3 (C2 cubic)
  int grid_newton_iterations = 30;
  /// Newton has no jitter (below): for its fixed quadrature, particles within this many grid
  /// cells of a fixture's or load's region boundary are split into 2 x 2 x 2 sub-points, which
  /// close the gap between the region and the first particle layer where a field could otherwise
  /// hide a displacement ramp.
  double grid_refine_band = 1.0;
  /// The grid Newton's quadrature weights are (1 - f) volumes + f energyWeights() with f this
  /// share: surface particles carry a small part of their neighbours' volume. Without it, grid nodes
  /// that only the outermost interior particles see extrapolate freely to the surface (NeRF
  /// particles of the T-bar: one corner particle moved 287 mm in a 60 mm twist); energyWeights' full
  /// share (f = 1) overstates a twisted section's surface strain (6 % error). README "Mechanics".
  double grid_surface_share = 0.04;
  /// The grid Newton's volume quadrature. kParticles: the particles' own volumes
  /// (midpoint rule; grid_surface_share and grid_refine_band apply): right on lattice layouts,
  /// but a sampler's gap between its outermost interior particles and the surface lets the
  /// energy drop without bound there (the equilibrium checks then refuse the answer). kCells:
  /// Gauss points in the grid's cells where the body is, cut cells moment-fitted
  /// (cell_quadrature.hpp), independent of the sampler (default); measured in docs/dem_feature_grid.md.
  enum class GridQuadrature { kCells, kParticles };
  GridQuadrature grid_quadrature = GridQuadrature::kCells;
  int grid_gauss_points = 2;      ///< Gauss points per axis and cell (kCells)
  int grid_boundary_levels = 1;   ///< times a cut cell is split in 2 x 2 x 2 (kCells)
  /// With grid_cell and grid_spacings 0: a grid whose cells hold the body's volume this many times,
  /// cell = (V / grid_body_cells)^(1/3), so the grid follows the body and not the particles (but
  /// never finer than the particle spacing); 0: no grid unless grid_cell or grid_spacings asks.
  /// 600 gives the T-bar's 60 mm section 4 cells of 15 mm (docs/dem_feature_grid.md).
  double grid_body_cells = 600.0;
  /// Extended B-splines (bspline_extension.hpp): grid nodes whose support holds no cell the
  /// quadrature fills to this share are extrapolated from a filled cell nearby instead of being
  /// unknowns, which removes the near-singular slivers of cut cells (0: off).
  double grid_extension_fill = 0.75;
  /// Load steps (0: the scenario's, or 1 with the feature grid: Newton with its line search takes
  /// the T-bar twist in one, 4 s, where the scenario's 4 steps take 9 s; a failed step is halved).
  int load_steps = 0;
  /// Stochastic quadrature near fixtures: particles within jitter_band cells of a fixture move at
  /// random within their cell at every Adam step, so the network cannot hide a displacement ramp
  /// between the fixture and the first particle layer (u = D z with z ~ T / D is a free rigid
  /// translation T away from the fixture otherwise). Particles further away keep fixed points and
  /// precomputed lift values.
  bool jitter = true;
  /// Only particles within this many cells (cube root of the particle volume) of a fixture are
  /// jittered; the default jitters all: a loaded surface needs it as much as a fixture (a strain
  /// layer under the traction patch between sample points harvests work too).
  double jitter_band = 1e9;
  /// L-BFGS polish per load step on the fixed particles (0: off). It is rejected (the Adam state
  /// kept) when it lowers the energy by more than polish_max_energy_drop x |Pi| or grows the
  /// largest displacement by more than polish_max_growth: the signature of the ramp exploit.
  int lbfgs_iterations = 0;
  int lbfgs_history = 50;
  /// A legitimate polish after a short Adam run lowers Pi 3.5x and grows max |u| 4x on the T-bar;
  /// the exploit lowers Pi ~100x with |u| larger than the body (README "Mechanics").
  double polish_max_energy_drop = 10.0;
  double polish_max_growth = 10.0;
  double tolerance = 1e-10;            ///< L-BFGS stops when the loss changes less than this
  int max_halvings = 4;                ///< load-step halvings after an inverted or NaN solve
  /// Torch threads; 0 = 1 thread below 50k particles (faster there on loaded 2-core machines),
  /// all cores above.
  int threads = 0;
  /// Raise glibc's mmap threshold (process-wide) so per-step activation buffers are reused
  /// instead of page-faulted in fresh every Adam step (about 1.8x at T-bar sizes).
  bool tune_allocator = true;
  /// Parametric mode (instant response to new loads): the load fraction s (scaling every load,
  /// body force and prescribed displacement of the scenario) is a fourth network input and
  /// u = s (g + D z(X, s)); one training over s in [load_range_min, load_range_max] (must
  /// contain 1), then predict(points, s) answers any s in the range without retraining.
  /// Load steps, L-BFGS and the output-layer Newton do not apply.
  bool parametric = false;
  double load_range_min = 0.0;
  double load_range_max = 1.0;
  int parametric_samples = 4;  ///< load fractions drawn per Adam step
  int seed = 1;
  bool double_precision = false;       ///< float32 by default: 2x faster, accurate to < 1e-4
  bool verbose = false;
};

/// The paper's DEM: the MLP alone (no feature grid) trained by Adam, 1500 iterations per load
/// step, with the penalty boundary W_u * MSE_u. `demnerf simulate --method mlp`, dem_node
/// ~dem_method mlp.
DemConfig paperDemConfig();

/// `config` in parametric mode over its load_range: the MLP alone (the feature grid does not take
/// the load as an input), trained by Adam (paperDemConfig()'s iterations when config has none).
DemConfig parametricDemConfig(DemConfig config);

/// The feature-grid settings a user gave (`demnerf simulate` flags, dem_node parameters); absent
/// ones keep the config's values.
struct DemGridChoice {
  std::optional<double> cell, spacings, body_cells;
  std::optional<int> adam_iterations;
};

/// `config` with the user's grid choice, by the rules both front ends share: grid_body_cells given
/// without grid_spacings sizes the cells from the body (grid_spacings 0); any grid setting given
/// without adam_iterations means no Adam (the grid's Newton solve is the training).
DemConfig withGridChoice(DemConfig config, const DemGridChoice& choice);

struct DemReport {
  double seconds = 0.0;
  double energy = 0.0;        ///< total potential energy at full load (J)
  double min_J = 0.0;         ///< smallest det F over the particles
  int iterations = 0;         ///< optimiser iterations over all load steps
  int load_steps = 0;         ///< load steps taken, halvings included
  double output_scale = 0.0;  ///< displacement scale of the network output after rescaling (m)
  /// |discrete weak-form residual| / |load| at the answer: the grid Newton's gradient in the grid
  /// coefficients (NaN without a feature grid: an MLP is never at a stationary point of its loss).
  double residual = 0.0;
  bool polish_rejected = false;  ///< an L-BFGS polish was undone (exploit guard)
};

/// Everything a trained DemSolver is (what dem_model_io saves): the problem, the network's
/// weights (row-major out x in) and the scales that map its output to metres.
struct DemState {
  DemConfig config;
  core::Scenario scenario;
  core::ParticleCloud cloud;
  double output_scale = 1.0;
  double energy_scale = 1.0;
  double fraction = 0.0;
  bool rescaled = false;
  std::vector<Eigen::MatrixXd> weights;
  std::vector<Eigen::VectorXd> biases;
  Eigen::MatrixXd grid_coefficients;  ///< nodes x 3 (empty without a feature grid)
};

class DemSolver {
 public:
  /// Validates scenario and particles (core::Error before any training) and builds the network.
  DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config = {});
  ~DemSolver();
  DemSolver(DemSolver&&) noexcept;

  /// Trains over the scenario's load steps, warm-started from the current network (a second
  /// call after changing nothing converges at once). Throws SolveError when the solve inverts
  /// particles, diverges or does not converge even with the smallest load step, when the answer
  /// fails its equilibrium checks, or when the control's time limit or cancel flag stops it; the
  /// network then keeps the last good state.
  DemReport solve();
  /// Time budget, progress sink and cancel flag of the next solve() calls.
  void setControl(const SolveControl& control);
  /// Replaces the scenario's loads and fixtures (same material) for a warm-started re-solve.
  void setScenario(const core::Scenario& scenario);
  /// Displacement at arbitrary points, at the load the network was trained for.
  std::vector<Eigen::Vector3d> predict(const std::vector<Eigen::Vector3d>& points) const;
  /// Displacement at a load fraction: any value in the trained range in parametric mode (no
  /// retraining); otherwise only the trained fraction (core::Error says so).
  std::vector<Eigen::Vector3d> predict(const std::vector<Eigen::Vector3d>& points, double load_scale) const;
  /// Rest positions, displacement and von Mises stress at the particles, in their order.
  core::ResultField result() const;
  /// The same at any points and load fraction (the rules of predict(points, load_scale)).
  core::ResultField evaluate(const std::vector<Eigen::Vector3d>& points, double load_scale) const;
  /// The particles the network was trained on.
  const core::ParticleCloud& particles() const;
  /// The load fractions predict() accepts: [min, max] in parametric mode, else the trained one.
  std::pair<double, double> loadRange() const;

  /// Called every `every` optimiser iterations (Adam steps and L-BFGS evaluations) with the
  /// iteration count so far: progress bars, convergence curves (predict() may be called from it).
  void setProgressCallback(std::function<void(int iteration)> callback, int every);

  /// A copy of the trained state, and a solver rebuilt from one (checked like the constructor;
  /// layer shapes must match the config's width and depth).
  DemState state() const;
  static DemSolver fromState(const DemState& state);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::mechanics
