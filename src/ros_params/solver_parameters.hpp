#pragma once
// dem_node's solver parameters as the library's SimulateOptions, read the way `demnerf simulate`
// reads its settings: the DEM method's preset (~dem_method: grid | mlp), the file ~solver_config
// over it, then the namespaces ~dem, ~fem, ~pinn, ~voxel, ~control (and the key ~mesher): the
// sections of config/solvers.yaml, read by the same loader (same keys, checks and messages).

#include <ros/node_handle.h>

#include "demnerf/mechanics/simulate.hpp"
#include "ros_params/parameter_map.hpp"

namespace dem_nerf {

/// Also ~threads (torch threads of the DEM and the PINN; 0: all cores) and the live settings'
/// startup values (~dem_grid_spacings, ~fem_order, ~solve_time_limit, the names dynamic_reconfigure
/// uses), then the library's rules (mechanics::normalised). Throws core::Error naming the
/// parameter.
demnerf::mechanics::SimulateOptions readSolverParameters(const ros::NodeHandle& node);
demnerf::mechanics::SimulateOptions readSolverParameters(const ParameterMap& node);

}  // namespace dem_nerf
