#include "ros_params/solver_parameters.hpp"

#include <string>

#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "ros_params/parameters.hpp"
#include "ros_params/parameters_yaml.hpp"
#include "ros_params/renamed_parameters.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;
namespace dm = demnerf::mechanics;

/// The preset and the file, then the namespaces over them.
template <class Node>
dm::SimulateOptions presetFileAndNamespaces(const Node& node) {
  std::string method = "grid", file;
  node.param("dem_method", method, method);
  node.param("solver_config", file, file);
  if (method != "grid" && method != "mlp") throw Error("parameter ~dem_method must be grid or mlp, got '" + method + "'");
  dm::SimulateOptions options = dm::solverDefaults(method, file);
  const std::string yaml = parametersAsYaml(node, {"dem", "fem", "pinn", "voxel", "control", "mesher"});
  if (!yaml.empty()) options = dm::parseSolverConfig(yaml, "parameters ~dem, ~fem, ~pinn, ~voxel, ~control", options);
  return options;
}

/// The dynamic_reconfigure names' startup values (cfg/DemNodeLive.cfg), as a user sets them for
/// any reconfigure server; they override the namespaces, as they do once the node runs.
template <class Node>
void applyLiveStartupValues(const Node& node, dm::SimulateOptions& options, dm::DemChoice& choice) {
  if (node.hasParam("dem_grid_spacings")) {
    double spacings = 0.0;
    readNumber(node, "dem_grid_spacings", spacings, 0.0);
    choice.grid_spacings = spacings;
  }
  readCount(node, "fem_order", options.voxel.order, 1);
  if (options.voxel.order > 2) throw Error("parameter ~fem_order must be 1 or 2");
  readNumber(node, "solve_time_limit", options.control.time_limit, 0.0);
}

template <class Node>
dm::SimulateOptions read(const Node& node) {
  rejectRenamed(node, {{"dem_iterations", "~dem/adam/iterations"},
                       {"dem_grid_cell", "~dem/grid/cell"},
                       {"dem_grid_body_cells", "~dem/grid/body_cells"},
                       {"parametric", "~dem/parametric/enabled"},
                       {"load_range", "~dem/parametric/load_range_min and ~dem/parametric/load_range_max"}});
  dm::SimulateOptions options = presetFileAndNamespaces(node);
  dm::DemChoice choice;
  applyLiveStartupValues(node, options, choice);
  if (node.hasParam("threads")) {  // else the file's (or default) dem.threads and pinn.threads stand
    readCount(node, "threads", options.dem.threads, 0);
    options.pinn.threads = options.dem.threads;
  }
  try {
    options.dem = dm::normalised(options.dem, choice);  // the rules `demnerf simulate` applies to its flags
  } catch (const Error& error) {
    throw Error(std::string("parameters ~dem, ~dem_grid_spacings, ~solver_config: ") + error.what());
  }
  return options;
}

}  // namespace

dm::SimulateOptions readSolverParameters(const ros::NodeHandle& node) { return read(node); }

dm::SimulateOptions readSolverParameters(const ParameterMap& node) { return read(node); }

}  // namespace dem_nerf
