#pragma once
// Every parameter of dem_node, with its default; read and checked in one place.

#include <ros/ros.h>

#include <string>
#include <vector>

#include "demnerf/mechanics/simulate.hpp"
#include "ros_params/parameter_map.hpp"

namespace dem_nerf {

struct DemNodeConfig {
  std::string scenario;            ///< scenario YAML: material and initial fixtures/loads (required)
  std::string solver = "dem";      ///< dem | fem | pinn
  double contact_radius = 0.02;    ///< m: a wrench acts on surface particles this close to its frame origin
  std::string particles_frame = "world";
  std::string render_frame;        ///< optical frame to render the deformed object from (empty: no render)
  std::string model_path;          ///< NeRF model file for ~rendered until a ModelInfo on `model` names one
  int render_width = 160;          ///< render size and horizontal field of view, used until a
  int render_height = 120;         ///<   CameraInfo arrives on ~render_camera_info
  double render_fov = 60.0;        ///< degrees
  double tf_timeout = 0.2;         ///< s to wait for the wrench frame
  /// Everything the solvers take (ros_params/solver_parameters.hpp), as `demnerf simulate` reads
  /// it: the preset of ~dem_method (grid | mlp), the file ~solver_config, the namespaces ~dem,
  /// ~fem, ~pinn, ~voxel, ~control (the sections of config/solvers.yaml), ~threads, and the live
  /// settings' startup values ~dem_grid_spacings, ~fem_order, ~solve_time_limit.
  demnerf::mechanics::SimulateOptions solver_options;
  /// Hz: solves start at most this often (0: no limit). Wrenches arriving in between coalesce,
  /// so a 100 Hz stream of fast solves cannot take a core from the NeRF training beside it.
  double max_solve_rate = 2.0;
  /// Particle clouds with more points are refused before conversion. The issue-14 run took 6 GB
  /// for 2.09 M particles (about 3 kB each): 200 000 particles stay near 0.6 GB.
  int max_particles = 200000;
  /// s after which a running solve yields to a newer request (it is cancelled); quicker solves
  /// finish, so a fast wrench stream still gets answers. ~solve calls are never cancelled so.
  double supersede_after = 2.0;
  int max_render_pixels = 640 * 480;  ///< ~render_camera_info asking for more is refused
  /// Folder that receives <export_dir>/solve_<n>.vtu (ParaView) after each solve (empty: none).
  std::string export_dir;

  /// The solver options these parameters imply (solver_options).
  demnerf::mechanics::SimulateOptions simulateOptions() const { return solver_options; }

  /// Throws demnerf::core::Error naming the first bad parameter.
  static DemNodeConfig fromParameters(const ros::NodeHandle& private_node);
  /// The same from parameters held in memory (no master; an empty map gives the defaults).
  static DemNodeConfig fromParameters(const ParameterMap& parameters);
};

}  // namespace dem_nerf
