#include "nodes/dem/dem_node_config.hpp"

#include "ros_params/parameters.hpp"
#include "ros_params/solver_parameters.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

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
  config.solver_options = readSolverParameters(node);
  return config;
}

}  // namespace

DemNodeConfig DemNodeConfig::fromParameters(const ros::NodeHandle& node) { return read(node); }

DemNodeConfig DemNodeConfig::fromParameters(const ParameterMap& parameters) { return read(parameters); }

}  // namespace dem_nerf
