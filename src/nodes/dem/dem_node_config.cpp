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
  readNumber(node, "tf_timeout", config.tf_timeout, 0.0);
  readCount(node, "threads", config.threads, 0);
  return config;
}

}  // namespace dem_nerf
