#pragma once
// The small parametric DEM the DEM and DemSession tests train: the MLP alone (DemConfig's default
// is the feature-grid DEM), two hidden layers, one thread, load fractions [0, load_range_max].

#include "demnerf/mechanics/dem_solver.hpp"

namespace demnerf::mechanics::test {

inline DemConfig parametricMlp(int width, int adam_iterations, double load_range_max) {
  DemConfig config;
  config.grid.body_cells = 0.0;
  config.network.width = width;
  config.network.depth = 2;
  config.adam.iterations = adam_iterations;
  config.parametric.enabled = true;
  config.parametric.load_range_min = 0.0;
  config.parametric.load_range_max = load_range_max;
  config.threads = 1;
  return config;
}

}  // namespace demnerf::mechanics::test
