#pragma once
// nerf_node's algorithm parameters as the library configs, one namespace each, read by the same
// YAML loaders as the command line's files:
//   ~nerf        NerfConfig (the keys of a nerf.yaml: hash, field, occupancy, march, train, background),
//                over the file ~nerf_config; ~threads sets train.threads
//   ~extraction  SurfaceConfig (resolution, surface, opacity, threshold, box, ...), as `demnerf extract`
//   ~sampling    geometry::SamplerConfig (method, spacing, seed, ...), as `demnerf sample`

#include <ros/node_handle.h>

#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/nerf/config.hpp"
#include "pipeline/surface_config.hpp"
#include "ros_params/parameter_map.hpp"

namespace dem_nerf {

/// Each throws core::Error naming the parameter and the key.
demnerf::nerf::NerfConfig readNerfParameters(const ros::NodeHandle& node);
demnerf::nerf::NerfConfig readNerfParameters(const ParameterMap& node);
SurfaceConfig readSurfaceParameters(const ros::NodeHandle& node);
SurfaceConfig readSurfaceParameters(const ParameterMap& node);
demnerf::geometry::SamplerConfig readSamplerParameters(const ros::NodeHandle& node);
demnerf::geometry::SamplerConfig readSamplerParameters(const ParameterMap& node);

}  // namespace dem_nerf
