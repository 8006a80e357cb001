#pragma once
// What dem_node draws for a solved load case on ~markers: the fixtures' regions and an arrow per
// load, in ~particles_frame. Kept out of dem_node.cpp, which only wires things to ROS.

#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "demnerf/core/scenario.hpp"

namespace dem_nerf {

/// Fixture regions (translucent blue) and force arrows (from the load's patch, 0.05 m long for the
/// largest force) of the scenario, ids from 0.
visualization_msgs::MarkerArray resultMarkers(const demnerf::core::Scenario& scenario, const std::string& frame);

}  // namespace dem_nerf
