#pragma once
// Every parameter of dem_node, with its default; read and checked in one place.

#include <ros/ros.h>

#include <string>
#include <vector>

#include "demnerf/mechanics/simulate.hpp"

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
  int threads = 0;                 ///< torch threads (0: all cores)
  int fem_order = 1;               ///< FEM baseline: 1 linear tets (seconds), 2 quadratic (minutes on 10k particles)
  int dem_iterations = 1500;       ///< DEM Adam iterations per load step (0 by default with a grid)
  double dem_grid_cell = 0.0;      ///< DEM feature grid cell (m; 0: from dem_grid_spacings), DemConfig::grid_cell
  double dem_grid_spacings = 2.0;  ///< DEM feature grid cell in particle spacings (0 and no cell: MLP only)
  /// Hz: solves start at most this often (0: no limit). Wrenches arriving in between coalesce,
  /// so a 100 Hz stream of fast solves cannot take a core from the NeRF training beside it.
  double max_solve_rate = 2.0;
  /// DEM parametric mode: trained once over load scales in load_range (relative to the first
  /// load it solves); later loads that only scale it within the range are answered at once.
  bool parametric = false;
  std::vector<double> load_range{0.0, 1.5};
  /// Particle clouds with more points are refused before conversion. The issue-14 run took 6 GB
  /// for 2.09 M particles (about 3 kB each): 200 000 particles stay near 0.6 GB.
  int max_particles = 200000;
  double solve_time_limit = 60.0;  ///< s one solve may take (0: none); SolveControl::time_limit
  /// s after which a running solve yields to a newer request (it is cancelled); quicker solves
  /// finish, so a fast wrench stream still gets answers. ~solve calls are never cancelled so.
  double supersede_after = 2.0;
  int max_render_pixels = 640 * 480;  ///< ~render_camera_info asking for more is refused

  /// The solver options these parameters imply.
  demnerf::mechanics::SimulateOptions simulateOptions() const;

  /// Throws demnerf::core::Error naming the first bad parameter.
  static DemNodeConfig fromParameters(const ros::NodeHandle& private_node);
};

}  // namespace dem_nerf
