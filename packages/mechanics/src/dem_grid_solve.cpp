// The DEM's feature grid: its quadrature (the particles, or Gauss points in the grid's cells), its
// Newton solve with the MLP frozen (grid_field_newton.hpp), and the checks an answer must pass
// before solve() reports it.
#include <torch/torch.h>

#include <cmath>
#include <iostream>
#include <sstream>

#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/particle_quadrature.hpp"
#include "dem_solver_impl.hpp"

namespace demnerf::mechanics {

using torch::Tensor;
using torch_support::toTensor;

namespace {

// The fixtures whose region's whole volume is held (no held face): the cell quadrature splits the
// cells their boundaries cut (cell_quadrature.hpp, CellQuadratureConfig::held_volumes).
std::vector<core::Region> heldVolumes(const core::Scenario& scenario, const std::vector<HeldFace>& held) {
  std::vector<core::Region> volumes;
  for (std::size_t f = 0; f < scenario.fixtures.size(); ++f)
    if (!(f < held.size() && held[f].valid) && scenario.fixtures[f].constrained.any())
      volumes.push_back(scenario.fixtures[f].region);
  return volumes;
}

bool sameRegions(const std::vector<core::Region>& a, const std::vector<core::Region>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k].type != b[k].type || a[k].center != b[k].center || a[k].size != b[k].size ||
        a[k].radius != b[k].radius || a[k].normal != b[k].normal)
      return false;
  return true;
}

}  // namespace

// The grid Newton's quadrature: the particles' own volumes (midpoint rule) with a small share on
// the surface particles (DemConfig::grid_surface_share), interior particles near a fixture or
// load split into 2 x 2 x 2 sub-points of their cube (Newton has no jitter to catch a ramp
// between a region and the first particle layer).
void DemSolver::Impl::buildGridQuadrature() {
  if (config.grid.quadrature == DemConfig::GridQuadrature::kCells) {
    // The cell quadrature depends on the cloud, the grid and the held volumes: built once per
    // set of held volumes, not per scenario (a patch basis runs up to 27 scenarios on one solver,
    // all with the same fixtures).
    std::vector<core::Region> volumes = heldVolumes(scenario, held);
    if (!sameRegions(volumes, gq_held_volumes)) {
      gq_points.clear();
      for (CoarseLevel& level : coarse_levels) level.points.clear();
      gq_held_volumes = std::move(volumes);
    }
    if (gq_points.empty()) {
      CellQuadratureConfig cq;
      cq.points_per_axis = config.grid.gauss_points;
      cq.boundary_levels = config.grid.boundary_levels;
      cq.held_volumes = gq_held_volumes;
      cq.threads = config.threads;
      std::ostringstream what;
      what << "cell quadrature of the feature grid (cells of " << grid->cell() << " m)";
      cq.progress = [this, text = what.str()](double done) { setupTick(text, done); };
      CellQuadrature q = cellQuadrature(cloud, *grid, cq);
      gq_points = std::move(q.points);
      gq_volume = std::move(q.weights);
    }
    buildCoarseQuadratures();
  } else {
    buildParticleGridQuadrature();
  }
  gq_lift = dirichletLift(scenario, gq_points, length, &held);
  gq_x = toTensor(gq_points, dtype);
  gq_lift_t[0] = toTensor(gq_lift.g, dtype);
  gq_lift_t[1] = toTensor(gq_lift.grad_g, dtype);
  gq_lift_t[2] = toTensor(gq_lift.D, dtype);
  gq_lift_t[3] = toTensor(gq_lift.grad_D, dtype);
}

void DemSolver::Impl::buildParticleGridQuadrature() {
  // (1 - f) volumes + f energyWeights: both sum to the body's volume, so a homogeneous state
  // keeps its exact energy.
  const double f = config.grid.surface_share;
  std::vector<double> weight = cloud.volumes;
  if (f > 0) {
    const std::vector<double> shared = energyWeights(cloud);
    for (std::size_t i = 0; i < weight.size(); ++i) weight[i] = (1 - f) * weight[i] + f * shared[i];
  }
  gq_points.clear();
  gq_volume.clear();
  const double band = config.grid.refine_band * config.grid.cell;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!(weight[i] > 0)) continue;
    const Eigen::Vector3d& x = cloud.positions[i];
    const double half = 0.5 * std::cbrt(cloud.volumes[i]);
    // Near a region's boundary: within the band outside it, or a cube that reaches out of it
    // (deep inside a fixture the field is prescribed: no ramp to catch).
    const auto near = [&](const core::Region& region) {
      for (int c = 0; c < 8; ++c)
        if (!region.contains(x + half * Eigen::Vector3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1)))
          return regionDistance(region, x) <= band;
      return false;
    };
    bool split = false;
    for (const core::Fixture& f : scenario.fixtures) split = split || near(f.region);
    for (const core::Load& l : scenario.loads) split = split || near(l.region);
    if (cloud.volumes[i] > 0 && !cloud.isSurface(i) && split) {
      const double quarter = 0.5 * half;
      for (int c = 0; c < 8; ++c) {
        gq_points.push_back(x + quarter * Eigen::Vector3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1));
        gq_volume.push_back(weight[i] / 8);
      }
    } else {
      gq_points.push_back(x);
      gq_volume.push_back(weight[i]);
    }
  }
}

// The grid Newton's problem on a quadrature (points, weights, their lift and its tensors `lifted`
// at x) at load `scale`: the offset is the displacement without the free grid (with_grid false:
// the lift and the MLP's share) or the whole answer (with_grid true: the MLP's check, where the
// test basis starts from the answer).
GridFieldProblem DemSolver::Impl::fieldProblem(const std::vector<Eigen::Vector3d>& points,
                                               const std::vector<double>& weights, const DirichletLift& lift,
                                               const Tensor& x, const Tensor* lifted, double scale,
                                               bool with_grid) const {
  GridFieldProblem pb;
  pb.points = points;
  pb.volume = weights;
  pb.D = lift.D;
  pb.grad_D = lift.grad_D;
  for (double w : weights) pb.body.push_back(scale * w * scenario.body_force);
  const auto [u, grad_u] = displacement(x, lifted, true, scale, nullptr, with_grid);
  pb.offset = torch_support::toVectors(u);
  pb.grad_offset = torch_support::toMatrices(grad_u);
  if (xs.size(0) > 0) {
    pb.surface_points = torch_support::toVectors(xs);
    pb.surface_offset = torch_support::toVectors(displacement(xs, lift_s, false, scale, nullptr, with_grid).first);
    pb.surface_D = torch_support::toVectors(lift_s[2]);
    pb.surface_force = torch_support::toVectors(traction_area * scale);
  }
  return pb;
}

// Newton on the feature grid's coefficients with the MLP frozen (grid_field_newton.hpp), on the
// grid quadrature: the best field in MLP + grid with the MLP's share fixed.
// False when Newton does not converge within grid_newton_iterations (the load step then counts as
// failed and is halved).
bool DemSolver::Impl::solveGrid(double scale, int& iterations) {
  torch::NoGradGuard guard;
  solveCoarseLevels(scale, iterations);  // their answers start this Newton (dem_grid_nested.cpp)
  const GridFieldProblem pb = fieldProblem(gq_points, gq_volume, gq_lift, gq_x, gq_lift_t, scale, false);
  // The Newton unknowns are in metres: c C.
  Eigen::MatrixXd C = toEigen(grid_coef.detach()) * out_scale;
  GridNewtonOutcome outcome;
  try {
    outcome = minimiseGridField(pb, *material, *grid, C, newtonSettings(grid_newton_cache, iterations, scale));
  } catch (...) {
    setGridCoefficients(C / out_scale);
    throw;
  }
  iterations += outcome.iterations;
  last_grid = outcome;
  setGridCoefficients(C / out_scale);
  if (config.verbose)
    std::cerr << "dem: grid Newton " << outcome.iterations << " its, energy " << outcome.energy << ", min J "
              << outcome.min_J << ", residual " << outcome.residual << (outcome.converged ? "" : " (not converged)")
              << ", " << outcome.held << " weak unknowns held (rung " << outcome.hold_rung << ", " << outcome.released
              << " released), " << outcome.factorisations
              << " factorisations; assembly "
              << outcome.assembly_seconds << " s, factorisation " << outcome.factorisation_seconds
              << " s, line search " << outcome.line_search_seconds << " s\n";
  return outcome.converged;
}

std::string DemSolver::Impl::gridFailureAdvice() const {
  std::ostringstream text;
  text << "The feature grid's Newton solve (cells of " << config.grid.cell << " m) did not reach an equilibrium"
       << (last_grid.min_J > 0 ? "" : " or inverted the material") << " (last residual " << last_grid.residual
       << ", smallest det F " << last_grid.min_J
       << "). Likely causes: a load too large for the material (try a smaller load or more load_steps), a fixture "
          "that holds too little of the body, or a grid too coarse for the body's thinnest part (raise "
          "grid_body_cells or lower grid_cell); grid_newton_iterations raises the iteration cap.";
  return text.str();
}

// The equilibrium checks an answer must pass before solve() reports success: the grid Newton's
// first-order condition, and a potential energy no higher than the undeformed state's (0 J when
// no fixture prescribes a displacement: any minimiser does at least as well as u = 0).
void DemSolver::Impl::checkAnswer(const DemReport& report) const {
  if (grid && !(last_grid.converged && report.residual <= 10 * GridNewtonConfig{}.residual_tolerance))
    throw SolveError(SolveFailure::kNotConverged,
                     "DEM: the answer is not an equilibrium (relative residual " + std::to_string(report.residual) +
                         "); " + gridFailureAdvice());
  bool prescribed = false;
  for (const core::Fixture& f : scenario.fixtures) prescribed = prescribed || f.displacement.norm() > 0;
  const double slack = 1e-9 * energy_scale + 1e-12;
  if (!prescribed && !(report.energy <= slack))
    throw SolveError(SolveFailure::kNotConverged,
                     "DEM: the answer's potential energy " + std::to_string(report.energy) +
                         " J is above the undeformed state's 0 J, so it is no minimum under these dead loads; " +
                         (grid ? gridFailureAdvice() : std::string("train longer (adam_iterations) or use the feature grid")));
}

}  // namespace demnerf::mechanics
