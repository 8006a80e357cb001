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

}  // namespace demnerf::mechanics
