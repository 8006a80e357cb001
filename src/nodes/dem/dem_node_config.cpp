#include "nodes/dem/dem_node_config.hpp"

#include <type_traits>

#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "ros_params/parameters.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

/// The solver settings: the DEM method's preset, ~solver_config over it, then the parameters that
/// are set (as `demnerf simulate`: preset, --config, flags).
template <class Node>
demnerf::mechanics::SimulateOptions readSolverOptions(const Node& node, const DemNodeConfig& config) {
  if (config.dem_method != "grid" && config.dem_method != "mlp")
    throw Error("parameter ~dem_method must be grid or mlp, got '" + config.dem_method + "'");
  demnerf::mechanics::SimulateOptions options = demnerf::mechanics::solverDefaults(config.dem_method, config.solver_config);
  demnerf::mechanics::DemConfig& dem = options.dem;
  demnerf::mechanics::DemChoice choice;
  const auto given = [&](const char* name, auto& field, auto value, auto minimum) {
    if (!node.hasParam(name)) return;
    if constexpr (std::is_same_v<decltype(value), int>) readCount(node, name, value, minimum);
    else readNumber(node, name, value, minimum);
    field = value;
  };
  given("dem_iterations", choice.adam_iterations, dem.adam.iterations, 0);
  given("dem_grid_cell", choice.grid_cell, dem.grid.cell, 0.0);
  given("dem_grid_spacings", choice.grid_spacings, dem.grid.spacings, 0.0);
  given("dem_grid_body_cells", choice.grid_body_cells, dem.grid.body_cells, 0.0);
  readCount(node, "threads", dem.threads, 0);
  options.pinn.threads = dem.threads;
  readCount(node, "fem_order", options.voxel.order, 1);
  if (options.voxel.order > 2) throw Error("parameter ~fem_order must be 1 or 2");
  readNumber(node, "solve_time_limit", options.control.time_limit, 0.0);
  node.param("parametric", dem.parametric.enabled, dem.parametric.enabled);
  std::vector<double> range{dem.parametric.load_range_min, dem.parametric.load_range_max};
  node.param("load_range", range, range);
  if (range.size() != 2 || !(range[0] < range[1]) || range[0] > 1.0 || range[1] < 1.0)
    throw Error("parameter ~load_range must be [min, max] with min <= 1 <= max (scales of the trained load)");
  dem.parametric.load_range_min = range[0];
  dem.parametric.load_range_max = range[1];
  // The library's rules (grid means no Adam unless asked, parametric means the MLP alone), as
  // `demnerf simulate` applies them to its flags.
  try {
    dem = demnerf::mechanics::normalised(dem, choice);
  } catch (const Error& error) {
    throw Error(std::string("parameters ~dem_*, ~parametric, ~solver_config: ") + error.what());
  }
  return options;
}

template <class Node>
DemNodeConfig read(const Node& node) {
  DemNodeConfig config;
  node.param("scenario", config.scenario, config.scenario);
  node.param("solver", config.solver, config.solver);
  if (config.solver != "dem" && config.solver != "fem" && config.solver != "pinn") {
    throw Error("parameter ~solver must be dem, fem or pinn, got '" + config.solver + "'");
  }
  readNumber(node, "contact_radius", config.contact_radius, 0.0);
  node.param("particles_frame", config.particles_frame, config.particles_frame);
  node.param("render_frame", config.render_frame, config.render_frame);
  node.param("model_path", config.model_path, config.model_path);
  readCount(node, "render_width", config.render_width, 1);
  readCount(node, "render_height", config.render_height, 1);
  readNumber(node, "render_fov", config.render_fov, 1.0);
  if (config.render_fov >= 180.0) throw Error("parameter ~render_fov must lie below 180 degrees");
  readNumber(node, "tf_timeout", config.tf_timeout, 0.0);
  readNumber(node, "max_solve_rate", config.max_solve_rate, 0.0);
  readCount(node, "max_particles", config.max_particles, 1);
  readNumber(node, "supersede_after", config.supersede_after, 0.0);
  readCount(node, "max_render_pixels", config.max_render_pixels, 1);
  node.param("export_dir", config.export_dir, config.export_dir);
  node.param("dem_method", config.dem_method, config.dem_method);
  node.param("solver_config", config.solver_config, config.solver_config);
  config.solver_options = readSolverOptions(node, config);
  return config;
}

}  // namespace

DemNodeConfig DemNodeConfig::fromParameters(const ros::NodeHandle& node) { return read(node); }

DemNodeConfig DemNodeConfig::fromParameters(const ParameterMap& parameters) { return read(parameters); }

demnerf::mechanics::SimulateOptions DemNodeConfig::simulateOptions() const { return solver_options; }

}  // namespace dem_nerf
