// The DEM's named settings beside the struct's defaults (the feature-grid DEM), and the rules that
// turn a user's choice into a config: kept in one place so that `demnerf simulate` and dem_node
// cannot drift apart.

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/dem_solver.hpp"

namespace demnerf::mechanics {

// The MLP alone, solved as the DEM reference code solves it: full-batch L-BFGS with a strong-Wolfe
// line search, the fixtures held exactly (u = g + D z, the reference code's u = x z), one load
// step, 800 iterations, the loss and gradient by the fused kernel (network.fused). Measured on
// Beam3D (docs/dem_feature_grid.md, "The MLP alone"): Adam at 1500 steps leaves the tip 95 % off
// and the penalty boundary 26 % after 800 iterations; on the particles (mirrored jitter draws) the
// grid clouds pass but a Poisson cloud's midpoint rule is exploited (refused, tip 26 % / 7 % off at
// 1/6 / 1/10), so the quadrature is Gauss points in cells of one particle spacing, no finer than a
// sixth of the smallest dimension (lbfgs.cell_spacings): the tip within 0.9 % on the grid, Poisson
// and random clouds at 1/6 and 1/10, every answer passing the check. 30 x 3 in float32.
DemConfig paperDemConfig() {
  DemConfig config;
  config.grid.cell = 0.0;
  config.grid.spacings = 0.0;
  config.grid.body_cells = 0.0;
  config.network.width = 30;
  config.network.depth = 3;
  config.boundary.kind = DemConfig::Boundary::kExact;
  config.adam.iterations = 0;
  config.lbfgs.iterations = 800;
  config.lbfgs.sample_iterations = 20;  // with cells: the first draws' length, between output balances
  config.lbfgs.cell_spacings = 1.0;
  config.load_steps = 1;
  return config;
}

DemConfig parametricDemConfig(DemConfig config) {
  config.parametric.enabled = true;
  config.grid.cell = 0.0;
  config.grid.spacings = 0.0;
  config.grid.body_cells = 0.0;
  if (config.adam.iterations == 0) config.adam.iterations = kParametricAdamIterations;
  return config;
}

namespace {

bool hasGrid(const DemConfig& config) {
  return config.grid.cell > 0 || config.grid.spacings > 0 || config.grid.body_cells > 0;
}

}  // namespace

DemConfig normalised(DemConfig config, const DemChoice& choice) {
  const bool grid_given = choice.grid_cell || choice.grid_spacings || choice.grid_body_cells;
  if (choice.grid_cell) config.grid.cell = *choice.grid_cell;
  if (choice.grid_spacings) config.grid.spacings = *choice.grid_spacings;
  if (choice.grid_body_cells) {
    config.grid.body_cells = *choice.grid_body_cells;
    if (!choice.grid_spacings) config.grid.spacings = 0.0;  // the body, not the particles, sizes the cells
  }
  // The grid's Newton solve is the training: a grid chosen without Adam steps takes none.
  if (choice.adam_iterations) config.adam.iterations = *choice.adam_iterations;
  else if (grid_given) config.adam.iterations = 0;
  if (choice.load_range) {
    if (grid_given)
      throw core::Error("a parametric load range trains the MLP alone (the feature grid does not take the load as an "
                        "input): drop the grid setting (--grid-cell / --grid-spacings / --grid-body-cells, "
                        "~dem/grid/*) or the load range");
    const auto [lo, hi] = *choice.load_range;
    if (!(lo < hi) || lo > 1.0 || hi < 1.0)
      throw core::Error("the parametric load range must be MIN,MAX with MIN < MAX and MIN <= 1 <= MAX (scales of the "
                        "scenario's load), got " + std::to_string(lo) + "," + std::to_string(hi));
    config.parametric.enabled = true;
    config.parametric.load_range_min = lo;
    config.parametric.load_range_max = hi;
  }
  if (config.parametric.enabled) return parametricDemConfig(config);
  if (config.output_newton.enabled && hasGrid(config))
    throw core::Error("the output-layer Newton (--newton, output_newton.enabled) solves the MLP's output layer, which "
                      "the feature grid takes over: use the MLP alone (--method mlp --boundary exact --newton)");
  return config;
}

}  // namespace demnerf::mechanics
