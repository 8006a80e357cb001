#pragma once
// Every parameter of dem_node, with its default; read and checked in one place.

#include <ros/ros.h>

#include <string>

namespace dem_nerf {

struct DemNodeConfig {
  std::string scenario;            ///< scenario YAML: material and initial fixtures/loads (required)
  std::string solver = "dem";      ///< dem | fem | pinn
  double contact_radius = 0.02;    ///< m: a wrench acts on surface particles this close to its frame origin
  std::string particles_frame = "world";
  std::string render_frame;        ///< optical frame to render the deformed object from (empty: no render)
  double tf_timeout = 0.2;         ///< s to wait for the wrench frame
  int threads = 0;                 ///< torch threads (0: all cores)

  /// Throws demnerf::core::Error naming the first bad parameter.
  static DemNodeConfig fromParameters(const ros::NodeHandle& private_node);
};

}  // namespace dem_nerf
