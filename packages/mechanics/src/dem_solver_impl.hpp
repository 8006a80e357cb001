#pragma once
// DemSolver's state and parts, private to packages/mechanics/src. The DEM's pieces live in their
// own translation units around this one struct:
//   dem_field.cpp      the displacement u = s g + D (z_MLP + z_grid) and its gradient
//   dem_energy.cpp     the potential energy on the particles (jittered near fixtures) and the
//                      output-amplitude line search
//   dem_grid_solve.cpp the feature grid's quadrature, its Newton solve and the equilibrium checks
//   dem_mlp_check.cpp  the equilibrium check of the MLP alone (no grid of its own to solve on)
//   dem_training.cpp   one load step: output-layer Newton, Adam, L-BFGS polish; parametric training
//   dem_solver.cpp     the public DemSolver: validation, particle sets, load stepping, answers

#include <Eigen/Core>
#include <chrono>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "demnerf/mechanics/material.hpp"
#include "displacement_mlp.hpp"
#include "torch_solver_support.hpp"

namespace demnerf::mechanics {

class ExploitGuard;
namespace mlp_kernel {
struct Network;
}

struct DemSolver::Impl {
  using Tensor = torch::Tensor;

  core::ParticleCloud cloud;
  core::Scenario scenario;
  std::vector<HeldFace> held;  // what each fixture holds (held_face.hpp), fitted to the cloud per scenario
  DemConfig config;
  std::string coarse_grid;  ///< ResolvedDemConfig::coarse_grid, for every report
  std::unique_ptr<HyperelasticMaterial> material;
  torch::Dtype dtype = torch::kFloat64;
  double length = 1.0, out_scale = 1.0, energy_scale = 1.0;
  DisplacementMlp net;
  // Particle subsets: volume particles (energy, body force), surface particles (traction) and,
  // in penalty mode, constrained particles. The volume particles are ordered fixed-first: the last
  // n_band of them lie near a fixture and are jittered during Adam.
  Tensor xv, vol, body, lift_v[4];
  long n_band = 0;
  std::vector<Eigen::Vector3d> band_points;  // nominal positions of the band particles
  std::vector<double> band_jitter;           // half cell size of each (0: not jittered)
  mutable std::mt19937 rng{1};
  Tensor xs, traction_area, lift_s[4];
  Tensor xc, fixed_value, fixed_mask;
  Tensor eye3;
  double fraction = 0.0;          // load fraction the network currently represents
  double load_input_scale = 1.0;  // parametric: largest |load fraction| of the trained range
  bool rescaled = false;          // the output amplitude was fitted (first solve only)
  std::function<void(int)> progress;
  int progress_every = 0;
  // The caller's budget and listeners (setControl), the running solve's clock, the load fraction
  // of the last good state and the last grid Newton's outcome (energy and residual of the answer).
  SolveControl control;
  std::unique_ptr<SolveClock> clock;
  // Set by the constructor given a control: the next solve()'s budget counts from here (set-up included).
  std::optional<std::chrono::steady_clock::time_point> setup_start;
  double done_fraction = 0.0;
  GridNewtonOutcome last_grid;

  // Feature grid (DemConfig::grid.cell): the basis, its coefficients (a parameter, in units of the
  // output scale like the MLP's output) and the supports of the fixed point sets.
  struct GridSupport {
    Tensor nodes, N, dN;  // [n, S] node indices, [n, S] values, [n, S, 3] X-gradients
  };
  std::unique_ptr<BsplineGrid> grid;
  Tensor grid_coef;
  GridSupport grid_v, grid_s;
  // The grid Newton's fixed quadrature (particles near fixtures split, DemConfig::grid.refine_band).
  std::vector<Eigen::Vector3d> gq_points;
  std::vector<double> gq_volume;
  std::vector<core::Region> gq_held_volumes;  // the fixture volumes the cell quadrature was built for
  DirichletLift gq_lift;
  GridNewtonCache grid_newton_cache;  // the last factorisation, across load steps and scenarios
  Tensor gq_x, gq_lift_t[4];
  // Nested grid solve (DemConfig::grid.nested_levels): coarser grids, coarsest first, each with its
  // cell quadrature, lift and factorisation cache; their Newton answers start the grid's Newton.
  struct CoarseLevel {
    std::unique_ptr<BsplineGrid> grid;
    std::vector<Eigen::Vector3d> points;
    std::vector<double> volume;
    DirichletLift lift;
    Tensor x, lift_t[4];
    GridNewtonCache cache;
  };
  std::vector<CoarseLevel> coarse_levels;

  // dem_field.cpp
  std::vector<Tensor> parameters() const;
  /// The exact boundary's lift at points. The MLP alone continues it linearly through held faces
  /// (dirichletLift's signed_faces): its cell quadrature puts points a little beyond them. The
  /// feature grid keeps |distance| (its answers are unchanged).
  DirichletLift liftAt(const std::vector<Eigen::Vector3d>& points) const {
    return dirichletLift(scenario, points, length, &held, !grid);
  }
  GridSupport gridSupport(const std::vector<Eigen::Vector3d>& points) const;
  GridSupport gridSupport(const Tensor& x) const { return gridSupport(torch_support::toVectors(x)); }
  std::pair<Tensor, Tensor> gridField(const GridSupport& support, bool gradient) const;
  void setGridCoefficients(const Eigen::MatrixXd& C);
  DisplacementMlp::Output hidden(const Tensor& x, bool jacobian, double scale) const;
  std::pair<Tensor, Tensor> displacement(const Tensor& x, const Tensor* lift, bool gradient, double scale,
                                         const GridSupport* support = nullptr, bool with_grid = true) const;
  void basisAt(const Tensor& x, double scale, Eigen::MatrixXd& h, Eigen::MatrixXd* dh) const;
  double maxDisplacement(double scale) const;
  void checkLoadScale(double load_scale) const;

  // dem_energy.cpp. A draw of the jittered quadrature: the volume particles with the band moved
  // and the lift there, held over one run of the sampled L-BFGS; loss() uses it when given.
  struct JitterDraw {
    Tensor x, lift[4], vol, body;
  };
  JitterDraw drawJitter() const;
  Tensor loss(double scale, double* energy, double* min_J, bool jitter = false, const JitterDraw* draw = nullptr) const;
  double energyWithAmplitude(double scale, double alpha);
  // dem_fused_loss.cpp: the same loss on a draw by mlp_energy_kernel.hpp, its gradient into .grad.
  bool fusedLossAvailable() const;
  // The network as the hand-written kernels read it (the fused loss, the Gauss-Newton rows): the
  // float32 weights in place, valid until the parameters are next assigned.
  mlp_kernel::Network kernelNetwork() const;
  Tensor fusedLoss(double scale, const JitterDraw& draw, bool gradient, double* energy, double* min_J);
  // ...and the fixed cell quadrature lbfgs.cell_spacings asks for (built at the first solve), and
  // the same rule on the grid shifted by half a cell: points the training never sees, whose energy
  // tells an exploit of the training points from progress (sampledLbfgsRun).
  JitterDraw cell_draw, shifted_cell_draw;
  const JitterDraw& cellDraw();
  const JitterDraw& shiftedCellDraw();
  double shiftedCellEnergy(double scale);
  void keepGuardedBest(ExploitGuard& guard, double scale);
  JitterDraw cellQuadratureDraw(double shift);
  // dem_gauss_newton.cpp: DemConfig::gauss_newton's steps on the cell quadrature (fused kernel).
  bool gaussNewtonAvailable() const;
  /// Until `tolerance` (DemGaussNewtonConfig) says converged, or a cap; `reserve`: seconds kept
  /// free before the solve's time limit (a check still to come); `resume`: on from the last run's
  /// energies and damping (gauss_newton_resume), as if its tolerance had been this one.
  void gaussNewton(double scale, int& iterations, double tolerance, double reserve = 0.0, bool resume = false);
  void rescaleOutput(double scale);
  /// The parameters and, last, the output and energy scales: balanceOutput() moves the output's
  /// amplitude between the last layer and out_scale, so weights restored without the scale they
  /// were saved with give another field (a Gauss-Newton guard's kept state came back 2.3x too
  /// large, inverted, after a balance during the self-weight block's fold).
  std::vector<Tensor> snapshot() const {
    std::vector<Tensor> s = torch_support::snapshot(parameters());
    s.push_back(torch::tensor({out_scale, energy_scale}, torch::kFloat64));
    return s;
  }
  void restore(const std::vector<Tensor>& s) {
    torch_support::restore(parameters(), s);
    out_scale = s.back()[0].item<double>();
    energy_scale = s.back()[1].item<double>();
  }

  // dem_grid_solve.cpp
  void buildGridQuadrature();
  bool solveGrid(double scale, int& iterations);
  GridFieldProblem fieldProblem(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights,
                                const DirichletLift& lift, const Tensor& x, const Tensor* lifted, double scale,
                                bool with_grid) const;
  std::string gridFailureAdvice() const;
  // dem_grid_nested.cpp
  void makeCoarseLevels(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
  void buildCoarseQuadratures();
  void solveCoarseLevels(double scale, int& iterations);
  GridNewtonConfig newtonSettings(GridNewtonCache& cache, int before, double scale);
  void checkAnswer(const DemReport& report) const;

  // dem_mlp_check.cpp: the MLP-only DEM's equilibrium check, in the basis of the B-spline grid the
  // default DEM would build for this body and on that grid's cell quadrature (built at the first
  // check, kept: the cloud does not change).
  struct MlpCheck {
    double residual = 0.0;        // |weak-form residual| / |load| in the check basis, H^-1 norm
    double euclidean = 0.0;       // ...in the plain norm (reported, not checked)
    double correction = 0.0;      // the Newton step it implies, rel. L2 of the displacement
    double energy = 0.0, min_J = 0.0;  // the answer's, on the check quadrature
    double bound = 0.0;           // energy of the lift alone (0 J without prescribed displacements)
    double boundary_error = 0.0;  // penalty boundary: largest fixture miss / largest displacement
    double cell = 0.0;            // the check grid's cell (m)
  };
  std::unique_ptr<BsplineGrid> check_grid;
  std::vector<Eigen::Vector3d> check_points;
  std::vector<double> check_weights;
  // Adam's pace in this solve (the time-limit message's estimate of what the schedule needs).
  double adam_seconds = 0.0;
  int adam_steps = 0;
  // The check basis's cell: `grid` the 600-cell grid's for this body, `cell` what the check uses
  // (no finer than two particle spacings while the loads sit on the surface particles).
  struct CheckCell {
    double grid = 0.0, cell = 0.0, spacing = 0.0;
  };
  CheckCell checkCell() const;
  void buildCheckBasis();
  MlpCheck mlpEquilibrium(double scale);
  void checkMlpAnswer(const MlpCheck& check) const;
  /// The MLP's check on the answer at full load: a failure is thrown, or in parametric mode noted
  /// in report.unverified (its training over a load range is not refused, but said unverified).
  void verifyMlpAnswer(DemReport& report);
  std::string mlpAdvice() const;
  std::string adamPaceAdvice() const;

  // dem_solver.cpp
  struct LoadSizes {
    double volume, max_traction, max_prescribed;  // m^3, Pa, m: the a-priori scales' inputs
  };
  LoadSizes setParticleSets();
  void setLoadPoints(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& forces);

  // dem_training.cpp
  std::string keptState() const;
  void tick(const char* phase, double scale, int iterations, double energy, double residual);
  /// The set-up's progress ("setup: <what>", `done` its share, NaN: unknown) and the stop checks,
  /// while the constructor runs under a control (a no-op otherwise).
  void setupTick(const std::string& what, double done = std::numeric_limits<double>::quiet_NaN());
  void reportProgress(int iterations) const;
  bool newtonEnabled() const;
  void solveOutputLayer(double scale);
  bool train(double scale, int& iterations, DemReport& report);
  bool trainParametric(int& iterations);
  // dem_mlp_check.cpp: gauss_newton.recheck_tolerance's continuation, run on the solve's clock.
  void continueRefusedAnswer(int& iterations);

 private:
  // The parts of the above (same files).
  Tensor loadInput(const Tensor& x, double scale) const;
  void jitterBand(Tensor& x, Tensor (&lift)[4], bool mirrored = false) const;
  void orderBandLast(std::vector<long>& volume_particles);
  void buildParticleGridQuadrature();
  bool runAdam(double scale, int& iterations);
  void polishWithLbfgs(double scale, int& iterations, DemReport& report);
  void trainWithSampledLbfgs(double scale, int& iterations);
  static constexpr int kBalanceDraws = 4;  // jitter draws after which the output may be balanced
  bool balanceOutput(double scale);
  void sampledLbfgsRun(double scale, int& iterations, int count, bool fused, JitterDraw& draw,
                       std::chrono::steady_clock::time_point& last);
  // The exploit guard's verdict on the last L-BFGS run: empty, or why it kept an earlier state
  // (that state is then no converged minimum, and checkMlpAnswer refuses it).
  std::string exploit_kept;
  // How the last Gauss-Newton steps ended ("112 (converged: ...)"), for the check's advice, and
  // whether by their tolerance (the only ending recheck_tolerance continues from).
  std::string gauss_newton_ended;
  bool gauss_newton_converged = false;
  struct GaussNewtonResume {
    std::vector<double> energies;  // every step's energy, for the stop's window
    double damping = 0.0;
  } gauss_newton_resume;
  // The check continueRefusedAnswer made, which verifyMlpAnswer uses unless the answer moved since.
  std::optional<MlpCheck> made_check;
};

/// Row-major tensor (rows x cols) -> Eigen, in double.
Eigen::MatrixXd toEigen(const torch::Tensor& t);

}  // namespace demnerf::mechanics
