// The DEM's named settings beside the struct's defaults (the feature-grid DEM): kept in one place
// so that `demnerf simulate` and dem_node cannot drift apart.

#include "demnerf/mechanics/dem_solver.hpp"

namespace demnerf::mechanics {

DemConfig paperDemConfig() {
  DemConfig config;
  config.grid_cell = 0.0;
  config.grid_spacings = 0.0;
  config.grid_body_cells = 0.0;
  config.adam_iterations = 1500;
  config.boundary = DemConfig::Boundary::kPenalty;
  return config;
}

DemConfig parametricDemConfig(DemConfig config) {
  config.parametric = true;
  config.grid_cell = 0.0;
  config.grid_spacings = 0.0;
  config.grid_body_cells = 0.0;
  if (config.adam_iterations == 0) config.adam_iterations = paperDemConfig().adam_iterations;
  return config;
}

DemConfig withGridChoice(DemConfig config, const DemGridChoice& choice) {
  if (choice.cell) config.grid_cell = *choice.cell;
  if (choice.spacings) config.grid_spacings = *choice.spacings;
  if (choice.body_cells) {
    config.grid_body_cells = *choice.body_cells;
    if (!choice.spacings) config.grid_spacings = 0.0;  // the body, not the particles, sizes the cells
  }
  if (choice.adam_iterations) config.adam_iterations = *choice.adam_iterations;
  else if (choice.cell || choice.spacings || choice.body_cells) config.adam_iterations = 0;
  return config;
}

}  // namespace demnerf::mechanics
