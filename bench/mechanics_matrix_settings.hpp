#pragma once
// The solver matrix's command line (bench/mechanics_matrix.cpp lists every key): what to run,
// where the references and NeRF caches live, and the comparison columns' knobs.

#include <string>
#include <vector>

namespace demnerf::bench {

struct MatrixSettings {
  std::vector<std::string> scenarios, samplers, sources, solvers;
  std::vector<int> divisors;
  double time_limit = 60.0, ref_time_limit = 1800.0, fem_div = 0.0, nerf_seconds = 60.0, nerf_cpu_seconds = 0.0;
  double grid_spacings = 2.0, extension_fill = 0.75, body_cells = 0.0;  // the dem_cells / dem_ext columns
  int boundary_levels = 1, mlp_iters = -1, mlp_lbfgs = -1, gn_steps = -1, ref_div = 8, conv_div = 6, seed = 1;
  std::string out, docs, title, yaml, config;
  std::string clouds;  ///< a folder to write each row's cloud to as a PLY (empty: none)
  std::string nerf_config;  ///< a NeRF YAML over the defaults for the NeRF rows' training (e.g. train.seed)
  std::vector<std::string> rows;
  bool partial = false;
};

/// Reads key=value arguments; throws core::Error on inconsistent ones (yaml= with several scenarios).
MatrixSettings parseMatrixSettings(int argc, char** argv);

}  // namespace demnerf::bench
