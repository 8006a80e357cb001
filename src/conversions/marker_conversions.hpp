#pragma once
// Core types drawn as rviz markers: what dem_node draws for a solved load case on ~markers (the
// fixtures' regions and an arrow per load) and nerf_node's extracted surface on ~mesh. Kept out of
// the nodes, which only wire things to ROS.

#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "demnerf/core/particle_cloud.hpp"
#include "demnerf/core/scenario.hpp"

namespace dem_nerf {

/// Fixture regions (translucent blue) and force arrows (from the load's patch, 0.05 m long for the
/// largest force) of the scenario, ids from 0.
visualization_msgs::MarkerArray resultMarkers(const demnerf::core::Scenario& scenario, const std::string& frame);

/// The mesh as one TRIANGLE_LIST marker (namespace "nerf_mesh", translucent tan) in frame.
visualization_msgs::Marker meshMarker(const demnerf::core::TriangleMesh& mesh, const std::string& frame);

}  // namespace dem_nerf
