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

/// How fixtures are held (DemConfig::Boundary) and how the feature grid is integrated
/// (DemConfig::GridQuadrature); docs/dem_config.md.
enum class DemBoundary { kExact, kPenalty };
enum class DemGridQuadrature { kCells, kParticles };

/// The MLP z(X) of u = g + D z.
struct DemNetworkConfig {
  int width = 64;                   ///< hidden units per layer (64)
  int depth = 3;                    ///< hidden layers (3)
  std::string activation = "tanh";  ///< tanh | sigmoid | softplus | sin (tanh)
  int seed = 1;                     ///< random seed of the weights and the jitter (1)
  bool double_precision = false;    ///< float64 instead of float32 (false)
  /// The MLP alone's L-BFGS loss and gradient by the hand-written kernel (tanh, float32,
  /// neo_hookean; anything else uses autograd): the same energy at ~1/8 of the CPU (true)
  bool fused = true;
  /// The first layer's initial weights (Glorot-uniform bound) times this: larger gives the tanh
  /// features more variation over the body at the start (1)
  double first_layer_scale = 1.0;
  /// Inputs normalised by the body's smallest half-extent on every axis (a T-bar leg's section
  /// spans [-1, 1] both ways), not each axis by its own (the leg spans a fifth of x's range) (false)
  bool thickness_inputs = false;
};

/// How fixtures are held.
struct DemBoundaryConfig {
  DemBoundary kind = DemBoundary::kExact;  ///< kExact: u = g + D z; kPenalty: the paper's W_u MSE_u (kExact)
  double penalty_weight = 1e4;             ///< W_u of kPenalty, on MSE_u / L^2 with Pi / (mu V) (1e4)
};

/// Adam on the MLP (and the grid) per load step, full batch.
struct DemAdamConfig {
  int iterations = 0;               ///< steps per load step; 0: the grid's Newton alone is the training (0)
  double learning_rate = 1e-2;      ///< initial rate (1e-2)
  double final_rate_ratio = 0.02;   ///< the rate decays exponentially to rate x this over a step (0.02)
  int rescale_every = 25;           ///< output amplitude line search every N steps of the first load step; 0: never (25)
  int rescale_until = 200;          ///< ...during its first N steps (200)
  bool jitter = true;               ///< quadrature points move within their cell every step (true)
  double jitter_band = 1e9;         ///< only particles within this many cells of a fixture jitter (1e9: all)
};

/// Ritz-Newton on the MLP's output layer with the hidden layers frozen (exact boundary, no grid).
struct DemOutputNewtonConfig {
  bool enabled = false;  ///< before, during and after each step's Adam run (false)
  int every = 0;         ///< also every N Adam steps; 0: only before and after (0)
  int iterations = 12;   ///< Newton iterations per solve (12)
};

/// L-BFGS per load step (strong-Wolfe line search): a polish on the fixed particles with the
/// exploit guard, or, with `sample_iterations` > 0 and adam.jitter, the training itself on the
/// jittered quadrature, a fresh draw every sample_iterations iterations (a fixed draw is exploited:
/// docs/dem_feature_grid.md, "The MLP alone").
struct DemLbfgsConfig {
  int iterations = 0;              ///< 0: off (0)
  int sample_iterations = 0;       ///< iterations per jitter draw; 0: one polish on the fixed particles (0)
  int history = 50;                ///< history length (50)
  double max_energy_drop = 10.0;   ///< reject a polish lowering Pi by more than this x |Pi| (10)
  double max_growth = 10.0;        ///< ...or growing max |u| by more than this factor (10)
  double tolerance = 1e-10;        ///< stop when the loss changes less than this (1e-10)
  /// > 0: the sampled L-BFGS integrates on Gauss points (2 per axis) in cells of this many
  /// particle spacings over the body the cloud describes (cell_quadrature.hpp), one fixed
  /// quadrature, instead of jitter draws of the particles; 0: the particles (0)
  double cell_spacings = 0.0;
  /// With cell_spacings: times a cell the surface cuts is split 2 x 2 x 2 before its inside part is
  /// moment-fitted (cell_quadrature.hpp); 0 fits the whole cut cell's 8 points (0)
  int cell_boundary_levels = 0;
};

/// Gauss-Newton steps after the L-BFGS, the MLP alone (issue 13: L-BFGS stalls on the T-bar twist,
/// whose displacement gradient is nearly all rotation). G = sum_q w_q J_q^T C J_q in the network's
/// parameters, J_q the Jacobian of the Green strain at a Gauss point of the cell quadrature (a
/// rigid rotation costs nothing), C the material's tangent at zero strain; formed each step on
/// `sample` Gauss points drawn at random; the step solves (G + mu mean(diag G) I) d = -grad, mu
/// Levenberg-Marquardt on the true energy's decrease. Needs the fused kernel's MLP (float32, tanh,
/// no grid, not parametric), the exact boundary and lbfgs.cell_spacings > 0.
struct DemGaussNewtonConfig {
  int steps = 0;          ///< most steps per load step; 0: off (0)
  /// Converged: the energy fell by less than tolerance x |E| over the last `window` steps; the
  /// steps stop there, before `steps` or the solve's time limit, the other two caps (0: no such
  /// stop) (2e-3)
  double tolerance = 2e-3;
  int window = 10;  ///< steps the energy change is measured over (10)
  int sample = 1000;      ///< Gauss points G is formed on, drawn afresh each step (1000)
  double damping = 1e-3;  ///< mu's start, relative to G's mean diagonal (1e-3)
  /// The draw: `spread` picks the points systematically along the cells' order with probability
  /// proportional to their weights (each then weighs total / sample), so every part of the body
  /// is in every draw and cut cells' light points are not drawn as often as whole cells' (false:
  /// a uniform draw of indices, weights rescaled to the total)
  bool spread = false;
  /// C at each drawn point's current strain (the Neo-Hookean's tangent; the decoupled law keeps
  /// zero strain) instead of at zero strain: what the self-weight block's compressed base needs
  /// (false)
  bool current_tangent = false;
  /// When the equilibrium check refuses an answer whose steps stopped converged (by `tolerance`)
  /// and the solve's time limit leaves room: the steps go on from that answer (its energies'
  /// window and damping) until the energy falls by less than this x |E| over `window` steps (a
  /// new cap of `steps`, an exploit guard of their own), and the check, unchanged, is asked
  /// again (0: refused at once) (0)
  double recheck_tolerance = 0.0;
};

/// The B-spline feature grid u = g + D o c (z(X) + N(X) C), C solved by Newton (exact boundary,
/// not parametric). Its cell: `cell` if > 0, else `spacings` particle spacings if > 0, else
/// (V / body_cells)^(1/3) if body_cells > 0 (never finer than the particles), else no grid.
struct DemGridConfig {
  double cell = 0.0;              ///< cell edge in m (0: from spacings or body_cells)
  double spacings = 0.0;          ///< cell in particle spacings (0: from body_cells)
  double body_cells = 2000.0;     ///< most cells the body's volume holds (2000; 0 with the others 0: MLP alone)
  /// With body_cells: the cell is no finer than the body's mean thickness 4 V / A (a square bar's
  /// side) over this many, so compact bodies keep coarser cells than slender ones (6; 0: off)
  double thickness_cells = 6.0;
  /// With body_cells: the cell is no finer than sqrt(A / surface_cells), so about this many cells
  /// meet the surface: a ragged one (a NeRF's sponge-like extraction) would otherwise make most
  /// cells cut cells, the costliest to set up and the weakest to solve (2000; 0: off)
  double surface_cells = 2000.0;
  /// With body_cells: a rough surface gets cells rough_cell_ratio times finer. Rough: its particles
  /// scatter about their local quadric (fitted over two cells) by more than this share of that
  /// radius; a NeRF extraction's bumps, not an exact mesh's faces or smooth curves. A cloud with
  /// fewer particles than body_cells keeps its cell (0.005; 0: off)
  double rough_surface = 0.005;
  double rough_cell_ratio = 0.8;  ///< cell factor on a rough surface, in (0, 1] (0.8)
  int degree = 2;                 ///< 1 trilinear, 2 C1 quadratic, 3 C2 cubic (2)
  DemGridQuadrature quadrature = DemGridQuadrature::kCells;  ///< Gauss points in cells, or the particles (kCells)
  int gauss_points = 2;           ///< Gauss points per axis and cell, kCells (2)
  int boundary_levels = 1;        ///< times a cut cell is split 2 x 2 x 2, kCells (1)
  double extension_fill = 0.25;   ///< nodes touching no cell filled this much are extrapolated; 0: off (0.25)
  int newton_iterations = 30;     ///< Newton iterations of the grid solve (30)
  /// Nested grid solve, kCells: each load step's Newton runs first on this many coarser grids
  /// (cells nested_ratio^k times larger, coarsest first), whose answers, moved to the grid by least
  /// squares, start its own Newton; the answer is the grid's (1; 0: off)
  int nested_levels = 1;
  double nested_ratio = 2.0;      ///< cell ratio between nested levels, > 1 (2)
  /// Nested solve: the grid's first Newton step with the points' strongly indefinite tangents
  /// projected positive semidefinite, which a start moved from the coarse level can have (true)
  bool projected_start = true;
  double refine_band = 1.0;       ///< particles within this many cells of a region split 2 x 2 x 2, kParticles (1)
  double surface_share = 0.04;    ///< share of energyWeights() in the particle weights, kParticles (0.04)
};

/// Parametric mode: the load fraction s is a network input, u = s (g + D z(X, s)), trained once
/// over [load_range_min, load_range_max]; the MLP alone (no grid, L-BFGS or output Newton).
struct DemParametricConfig {
  bool enabled = false;          ///< (false)
  double load_range_min = 0.0;   ///< smallest load fraction (0)
  double load_range_max = 1.0;   ///< largest load fraction, >= 1 (1)
  int samples = 4;               ///< load fractions drawn per Adam step (4)
};

/// Every DEM setting, grouped by the part of the solver it steers; the defaults are the product's
/// DEM (feature grid sized from the body, cell quadrature, Newton, no Adam). Each field: what it
/// is and its default; why each default is what it is (and the measurements) is in
/// docs/dem_config.md. config/solvers.yaml lists every key; `demnerf simulate` and dem_node start
/// from these values.
struct DemConfig {
  using Boundary = DemBoundary;
  using GridQuadrature = DemGridQuadrature;
  DemNetworkConfig network;
  DemBoundaryConfig boundary;
  DemAdamConfig adam;
  DemOutputNewtonConfig output_newton;
  DemLbfgsConfig lbfgs;
  DemGaussNewtonConfig gauss_newton;
  DemGridConfig grid;
  DemParametricConfig parametric;
  int load_steps = 0;           ///< 0: the scenario's, or 1 with the feature grid (a failed step is halved)
  int max_halvings = 4;         ///< load-step halvings after an inverted or NaN solve (4)
  /// Torch threads (0: 1 below 50k particles, all cores above), the grid Newton's assembly
  /// threads (0: all cores) and the MLP's fused loss kernel's (0: one per 1000 points, up to all cores).
  int threads = 0;
  /// The MLP alone's loads (no feature grid): spread evenly over the surface the particles describe,
  /// as the default DEM's (surface_loads.hpp), on a lattice of an eighth of the equilibrium check's
  /// cell (true); false: the paper's forces on the surface particles, which a check basis finer than
  /// two particle spacings resolves as point loads, so the check then stays that coarse.
  bool surface_loads = true;
  bool tune_allocator = true;   ///< raise glibc's mmap threshold, process-wide, to reuse Adam's buffers (true); applied by the entry point (dem_node, `demnerf simulate`): keepLargeAllocationsInHeap()
  bool verbose = false;         ///< print training details (false)
};

/// The paper's DEM, the MLP alone (no feature grid), as the DEM reference code trains it: 800
/// L-BFGS iterations on Gauss points in cells of one particle spacing (lbfgs.cell_spacings 1, no
/// finer than a sixth of the smallest dimension), the output balanced over the first draws
/// (lbfgs.sample_iterations 20), the fixtures held exactly, a 30 x 3 tanh network in float32
/// through the fused loss kernel, one load step. `demnerf simulate --method mlp`, dem_node
/// ~dem_method mlp; the paper's penalty W_u * MSE_u is `boundary.kind: penalty` over it.
DemConfig paperDemConfig();

/// Adam steps of parametric mode when the config it starts from has none.
constexpr int kParametricAdamIterations = 1500;

/// `config` in parametric mode over its load range: the MLP alone (the feature grid does not take
/// the load as an input), trained by Adam (kParametricAdamIterations when config has none).
DemConfig parametricDemConfig(DemConfig config);

/// The DEM settings a user gave over a preset (`demnerf simulate` flags, dem_node parameters);
/// absent ones keep the config's values.
struct DemChoice {
  std::optional<double> grid_cell, grid_spacings, grid_body_cells;
  std::optional<int> adam_iterations;
  std::optional<std::pair<double, double>> load_range;  ///< parametric mode over [min, max]
};

/// `config` with the user's choice, by the rules both front ends share: grid body_cells given
/// without spacings sizes the cells from the body (spacings 0); any grid setting given without
/// adam_iterations means no Adam (the grid's Newton solve is the training); a load range, or
/// parametric.enabled in `config`, means parametricDemConfig(). Throws core::Error when the choice
/// contradicts itself: a load range with a grid setting (the grid does not take the load), a
/// load range not containing 1, or the output-layer Newton with a feature grid.
DemConfig normalised(DemConfig config, const DemChoice& choice = {});

struct DemReport {
  double seconds = 0.0;
  double energy = 0.0;        ///< total potential energy at full load (J)
  double min_J = 0.0;         ///< smallest det F over the particles
  int iterations = 0;         ///< optimiser iterations over all load steps
  int load_steps = 0;         ///< load steps taken, halvings included
  double output_scale = 0.0;  ///< displacement scale of the network output after rescaling (m)
  /// |discrete weak-form residual| / |load| at the answer: the grid Newton's gradient in the grid
  /// coefficients; without a feature grid, the MLP's residual in the B-spline test basis of its
  /// equilibrium check (energy norm; dem_mlp_check.cpp, docs/dem_feature_grid.md).
  double residual = 0.0;
  /// Grid unknowns the body barely sees, held where they were because the Hessian was singular
  /// (GridNewtonConfig::weak_stiffness; 0 on a clean body), and their own relative residual, which
  /// `residual` leaves out.
  long held_unknowns = 0;
  double held_residual = 0.0;
  /// Parametric mode only: why its answer at the trained load failed the MLP's equilibrium check
  /// (empty: it passed). Its answers are kept and used, and this says they are not verified.
  std::string unverified;
  /// Why the answer will be stiff although it is an equilibrium (empty: none known): the particles
  /// were too coarse for the automatic grid to put four cells across the body's mean thickness.
  std::string coarse_grid;
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
  /// Validates scenario and particles (core::Error before any training) and builds the network
  /// and the feature grid's quadrature.
  DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config = {});
  /// The same under a solve's control: the set-up (the cell quadrature alone takes tens of seconds
  /// on a ragged body) reports progress (phases "setup ...") and counts against the time limit
  /// (SolveError{kTimeLimit} from here), and the first solve()'s budget starts at construction, so
  /// the limit holds in wall time from this call on.
  DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config, const SolveControl& control);
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
  DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config, const SolveControl* control);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::mechanics
