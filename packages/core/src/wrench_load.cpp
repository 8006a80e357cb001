#include "demnerf/core/wrench_load.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"

namespace demnerf::core {

Load loadFromWrench(const Eigen::Isometry3d& particles_from_wrench, const Eigen::Vector3d& force,
                    const Eigen::Vector3d& torque, double contact_radius, const std::string& name) {
  if (!force.allFinite() || !torque.allFinite()) throw Error("it holds NaN or Inf");
  if (!particles_from_wrench.matrix().allFinite()) throw Error("the wrench frame's pose holds NaN or Inf");
  if (!(contact_radius >= 0.0) || !std::isfinite(contact_radius))
    throw Error("the contact radius must be a length >= 0 m, got " + std::to_string(contact_radius));
  Load load;
  load.name = name;
  load.region.type = Region::Type::kSphere;
  load.region.center = particles_from_wrench.translation();
  load.region.radius = contact_radius;
  // Free vectors: only the rotation applies (the torque is about the wrench frame's origin, which
  // is the sphere's centre, so no moment arm appears).
  load.force = particles_from_wrench.linear() * force;
  load.torque = particles_from_wrench.linear() * torque;
  return load;
}

}  // namespace demnerf::core
