// The DEM feature grid's nested solve (DemConfig::grid.nested_levels): each load step's Newton
// runs first on coarser grids, whose answers start the Newton on the grid itself.
//
// Why: the grid's Newton from rest takes 12-14 iterations on the T-bar twist (a 21 degree twist
// in one load step), each an assembly and a sparse factorisation whose cost grows faster than the
// unknowns. A coarse grid takes the same iterations for a fraction of the cost, and from its answer
// the fine grid's Newton needs a few (docs/dem_feature_grid.md, "Nested grids"). Only the start
// changes: the answer is the fine grid's minimiser, held to the same convergence test and checks.
//
// Each coarse level solves for a correction C_k to the current field (the fine grid's share is in
// the level's offset, frozen), starting at zero, so no level can leave a worse state than it found;
// the correction is then continued onto the coarse nodes only the fine grid's points reach (the
// level's own points never saw them), moved onto the fine grid by weighted least squares at the
// fine grid's quadrature points (grid_transfer.hpp) and added to its coefficients.
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

#include "demnerf/mechanics/cell_quadrature.hpp"
#include "dem_solver_impl.hpp"
#include "grid_transfer.hpp"

namespace demnerf::mechanics {

using torch_support::toTensor;

namespace {
constexpr int kCoarseIterations = 16;  // Newton iterations of a coarse level
// The fill of the cells a coarse level's field is continued from (continueUnseenNodes) when the
// extension is off: the extension's default.
constexpr double kContinuationFill = 0.25;
}  // namespace

// The coarse grids over the fine grid's box (lo, hi), coarsest first.
void DemSolver::Impl::makeCoarseLevels(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  coarse_levels.clear();
  if (config.grid.quadrature != DemConfig::GridQuadrature::kCells) return;
  for (int k = config.grid.nested_levels; k >= 1; --k) {
    CoarseLevel level;
    level.grid = std::make_unique<BsplineGrid>(lo, hi, config.grid.cell * std::pow(config.grid.nested_ratio, k),
                                               config.grid.degree);
    coarse_levels.push_back(std::move(level));
  }
}

// Each level's cell quadrature (once per set of held volumes: it depends on the cloud, the grid
// and those) and its lift (per scenario), as buildGridQuadrature() does for the grid.
void DemSolver::Impl::buildCoarseQuadratures() {
  for (CoarseLevel& level : coarse_levels) {
    if (level.points.empty()) {
      const auto start = std::chrono::steady_clock::now();
      CellQuadratureConfig cq;
      cq.points_per_axis = config.grid.gauss_points;
      // A coarse level only starts the fine Newton: its cut cells are moment-fitted whole (no
      // split), which costs an eighth of the inside test's probes and of the points.
      cq.boundary_levels = 0;
      cq.held_volumes = gq_held_volumes;
      cq.threads = config.threads;
      std::ostringstream what;
      what << "cell quadrature of a nested grid (cells of " << level.grid->cell() << " m)";
      cq.progress = [this, text = what.str()](double done) { setupTick(text, done); };
      CellQuadrature q = cellQuadrature(cloud, *level.grid, cq);
      level.points = std::move(q.points);
      level.volume = std::move(q.weights);
      if (config.verbose)
        std::cerr << "dem: nested level (cells of " << level.grid->cell() << " m): " << level.points.size()
                  << " points in " << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
                  << " s\n";
    }
    level.lift = dirichletLift(scenario, level.points, length, &held);
    level.x = toTensor(level.points, dtype);
    level.lift_t[0] = toTensor(level.lift.g, dtype);
    level.lift_t[1] = toTensor(level.lift.grad_g, dtype);
    level.lift_t[2] = toTensor(level.lift.D, dtype);
    level.lift_t[3] = toTensor(level.lift.grad_D, dtype);
  }
}

GridNewtonConfig DemSolver::Impl::newtonSettings(GridNewtonCache& cache, int before, double scale) {
  GridNewtonConfig newton;
  newton.near_minimum = &cache == &grid_newton_cache && !coarse_levels.empty();
  newton.projected_start = newton.near_minimum && config.grid.projected_start;
  newton.max_iterations = config.grid.newton_iterations;
  // A coarse level only starts the grid's Newton, whose answer is the grid's own whatever the start:
  // it gets the T-bar twist's 13-14 iterations with a margin, not the whole cap (the fox's ragged
  // body spent 30 there, 25 s of a 43 s solve, for a start the fine Newton takes in 5).
  if (&cache != &grid_newton_cache) newton.max_iterations = std::min(newton.max_iterations, kCoarseIterations);
  newton.extension_fill = config.grid.extension_fill;
  newton.threads = config.threads;
  newton.cache = &cache;
  newton.on_iteration = [this, before, scale](int it, double energy, double residual) {
    tick("newton", scale, before + it, energy, residual);
  };
  return newton;
}

// The coarse levels' corrections at load `scale`, each added to the grid's coefficients. A level
// that does not converge still hands on its last (lower-energy) state: the fine Newton decides.
void DemSolver::Impl::solveCoarseLevels(double scale, int& iterations) {
  torch::NoGradGuard guard;
  for (CoarseLevel& level : coarse_levels) {
    const GridFieldProblem pb = fieldProblem(level.points, level.volume, level.lift, level.x, level.lift_t, scale, true);
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(level.grid->nodeCount(), 3);
    const GridNewtonOutcome outcome =
        minimiseGridField(pb, *material, *level.grid, C, newtonSettings(level.cache, iterations, scale));
    iterations += outcome.iterations;
    if (config.verbose)
      std::cerr << "dem: nested level (cells of " << level.grid->cell() << " m) " << outcome.iterations
                << " its, energy " << outcome.energy << ", residual " << outcome.residual << ", " << outcome.held
                << " weak unknowns held (rung " << outcome.hold_rung << ", " << outcome.released
                << " released); assembly " << outcome.assembly_seconds << " s, factorisation "
                << outcome.factorisation_seconds << " s\n";
    if (outcome.iterations == 0) continue;
    // The fine grid sees more of a ragged body than the level (whose cut cells are not split): the
    // level's field is continued onto the nodes only the fine points reach before it is moved.
    const double fill = config.grid.extension_fill > 0 ? config.grid.extension_fill : kContinuationFill;
    const long continued = continueUnseenNodes(*level.grid, C, level.points, level.volume, gq_points, fill);
    if (config.verbose && continued > 0)
      std::cerr << "dem: nested level's field continued onto " << continued << " nodes it did not see\n";
    // The Newton's unknowns are in metres (c C): the grid's parameter is in units of the output scale.
    const Eigen::MatrixXd moved = transferGridField(*level.grid, C, *grid, gq_points, gq_volume);
    setGridCoefficients(toEigen(grid_coef.detach()) + moved / out_scale);
  }
}

}  // namespace demnerf::mechanics
