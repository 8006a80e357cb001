#pragma once
// One configuration for every solver: DemConfig, FemConfig, PinnConfig, the FEM mesh settings and
// the solve's time budget read from one YAML file whose keys are the struct fields, grouped as in
// SimulateOptions, DemConfig's parts as nested sections (config/solvers.yaml lists every key with
// its default and meaning):
//
//   dem:     {load_steps: 0, grid: {cell: 0, body_cells: 2000}, network: {width: 64}, ...}  DemConfig
//   fem:     {linear_solver: ldlt, ordering: amd, ...}             FemConfig
//   pinn:    {width: 64, ...}                                      PinnConfig
//   voxel:   {cell: 0, order: 2}                                   VoxelMeshConfig (FEM mesh)
//   mesher:  cgal                                                  SimulateOptions::mesher
//   control: {time_limit: 60, progress_interval: 1}                SolveControl
//
// Keys left out keep the value they had. DemConfig's flat keys of earlier files (dem: {grid_cell:
// 0.02}) are read as their nested names (docs/dem_config.md). `demnerf simulate --config` and dem_node's
// ~solver_config both read it with loadSolverConfig, over solverDefaults().

#include <string>
#include <vector>

#include "demnerf/mechanics/simulate.hpp"

namespace demnerf::mechanics {

/// "grid" (the feature-grid DEM, DemConfig's defaults) or "mlp" (paperDemConfig()); core::Error
/// naming the value otherwise.
DemConfig demConfigForMethod(const std::string& method);

/// What the CLI and dem_node start from before their own flags and parameters: the DEM of
/// `dem_method`, every other setting at its struct default, then the file `config_path` over it
/// (empty: no file).
SimulateOptions solverDefaults(const std::string& dem_method = "grid", const std::string& config_path = "");

/// The settings in the YAML file at `path` over `base`. Throws core::Error naming the file and the
/// key for unreadable files, invalid YAML, unknown sections or keys, values of the wrong type and
/// values out of range (e.g. "solvers.yaml: 'dem.network.width' must be an integer >= 1, got 0").
SimulateOptions loadSolverConfig(const std::string& path, SimulateOptions base = {});
/// The same from YAML text; `source` names it in messages.
SimulateOptions parseSolverConfig(const std::string& yaml_text, const std::string& source, SimulateOptions base = {});

/// Every key with its value in `options` and a one-line meaning, as a YAML file that
/// loadSolverConfig reads back to the same settings (config/solvers.yaml is this of the defaults).
std::string solverConfigYaml(const SimulateOptions& options);

/// Every key the loader knows, as "section.key" ("mesher" for the top-level key), in file order.
std::vector<std::string> solverConfigKeys();

}  // namespace demnerf::mechanics
