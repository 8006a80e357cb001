#pragma once
// A measured wrench (a force-torque sensor, a teleoperation device, rviz) as the load the solvers
// read. The wrench acts at its frame's origin; it is spread over the surface particles near that
// point, so the load is a sphere there. ROS-free: the node supplies the pose from tf.

#include <Eigen/Geometry>

#include <string>

#include "demnerf/core/scenario.hpp"

namespace demnerf::core {

/// The load of a wrench (force in N, torque in N m, both in the wrench's frame) whose frame sits
/// at particles_from_wrench in the particles' frame: a sphere of contact_radius (m) around the
/// frame's origin, force and torque rotated into the particles' frame. Throws core::Error when the
/// wrench or the pose holds NaN or Inf, or contact_radius is negative.
Load loadFromWrench(const Eigen::Isometry3d& particles_from_wrench, const Eigen::Vector3d& force,
                    const Eigen::Vector3d& torque, double contact_radius, const std::string& name);

}  // namespace demnerf::core
