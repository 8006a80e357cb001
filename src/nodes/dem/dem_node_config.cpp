#include "nodes/dem/dem_node_config.hpp"

#include "ros_params/parameters.hpp"

namespace dem_nerf {

DemNodeConfig DemNodeConfig::fromParameters(const ros::NodeHandle& node) {
  DemNodeConfig config;
  node.param("scenario", config.scenario, config.scenario);
  node.param("solver", config.solver, config.solver);
  if (config.solver != "dem" && config.solver != "fem" && config.solver != "pinn") {
    throw demnerf::core::Error("parameter ~solver must be dem, fem or pinn, got '" + config.solver + "'");
  }
  readNumber(node, "contact_radius", config.contact_radius, 0.0);
  node.param("particles_frame", config.particles_frame, config.particles_frame);
  node.param("render_frame", config.render_frame, config.render_frame);
  node.param("model_path", config.model_path, config.model_path);
  readCount(node, "render_width", config.render_width, 1);
  readCount(node, "render_height", config.render_height, 1);
  readNumber(node, "render_fov", config.render_fov, 1.0);
  if (config.render_fov >= 180.0) throw demnerf::core::Error("parameter ~render_fov must lie below 180 degrees");
  readNumber(node, "tf_timeout", config.tf_timeout, 0.0);
  readCount(node, "threads", config.threads, 0);
  readCount(node, "fem_order", config.fem_order, 1);
  if (config.fem_order > 2) throw demnerf::core::Error("parameter ~fem_order must be 1 or 2");
  readCount(node, "dem_iterations", config.dem_iterations, 0);
  readNumber(node, "dem_grid_cell", config.dem_grid_cell, 0.0);
  readNumber(node, "dem_grid_spacings", config.dem_grid_spacings, 0.0);
  node.param("parametric", config.parametric, config.parametric);
  // The feature grid does not take the load as an input: parametric mode trains the MLP alone.
  if (config.parametric) config.dem_grid_cell = config.dem_grid_spacings = 0.0;
  // With the feature grid its Newton solve is the training: Adam only when asked for.
  const bool grid = config.dem_grid_cell > 0 || config.dem_grid_spacings > 0;
  if (grid && !node.hasParam("dem_iterations")) config.dem_iterations = 0;
  readNumber(node, "max_solve_rate", config.max_solve_rate, 0.0);
  node.param("load_range", config.load_range, config.load_range);
  if (config.load_range.size() != 2 || !(config.load_range[0] < config.load_range[1]) || config.load_range[0] > 1.0 ||
      config.load_range[1] < 1.0)
    throw demnerf::core::Error("parameter ~load_range must be [min, max] with min <= 1 <= max (scales of the trained load)");
  readCount(node, "max_particles", config.max_particles, 1);
  readNumber(node, "solve_time_limit", config.solve_time_limit, 0.0);
  readNumber(node, "supersede_after", config.supersede_after, 0.0);
  readCount(node, "max_render_pixels", config.max_render_pixels, 1);
  return config;
}

demnerf::mechanics::SimulateOptions DemNodeConfig::simulateOptions() const {
  demnerf::mechanics::SimulateOptions options;
  options.voxel.order = fem_order;
  options.dem.adam_iterations = dem_iterations;
  options.dem.grid_cell = dem_grid_cell;
  options.dem.grid_spacings = dem_grid_spacings;
  options.dem.threads = threads;
  options.dem.parametric = parametric;
  options.dem.load_range_min = load_range[0];
  options.dem.load_range_max = load_range[1];
  options.pinn.threads = threads;
  options.control.time_limit = solve_time_limit;
  return options;
}

}  // namespace dem_nerf
