#include "conversions/region_conversions.hpp"

#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) { return {v.x, v.y, v.z}; }
Eigen::Vector3d toEigen(const geometry_msgs::Point& p) { return {p.x, p.y, p.z}; }

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 message;
  message.x = v.x();
  message.y = v.y();
  message.z = v.z();
  return message;
}

}  // namespace

demnerf::core::Region fromMessage(const dem_nerf::Region& message) {
  demnerf::core::Region region;
  region.center = toEigen(message.pose.position);
  if (!region.center.allFinite()) throw Error("region: centre holds NaN or Inf");
  switch (message.type) {
    case dem_nerf::Region::BOX:
      region.type = demnerf::core::Region::Type::kBox;
      region.size = toEigen(message.size);
      if (!region.size.allFinite() || (region.size.array() <= 0).any()) {
        throw Error("region: box size must be positive and finite");
      }
      break;
    case dem_nerf::Region::SPHERE:
      region.type = demnerf::core::Region::Type::kSphere;
      region.radius = message.radius;
      if (!std::isfinite(region.radius) || region.radius <= 0) throw Error("region: sphere radius must be positive");
      break;
    case dem_nerf::Region::HALFSPACE:
      region.type = demnerf::core::Region::Type::kHalfspace;
      region.normal = toEigen(message.normal);
      if (!region.normal.allFinite() || region.normal.norm() < 1e-12) throw Error("region: halfspace normal must be non-zero");
      region.normal.normalize();
      break;
    default:
      throw Error("region: type " + std::to_string(message.type) + " is unknown (BOX=0, SPHERE=1, HALFSPACE=2)");
  }
  return region;
}

demnerf::core::Fixture fromMessage(const dem_nerf::Fixture& message) {
  demnerf::core::Fixture fixture;
  fixture.name = message.name;
  try {
    fixture.region = fromMessage(message.region);
  } catch (const Error& error) {
    throw Error("fixture '" + message.name + "': " + error.what());
  }
  fixture.displacement = toEigen(message.displacement);
  if (!fixture.displacement.allFinite()) throw Error("fixture '" + message.name + "': displacement holds NaN or Inf");
  return fixture;
}

demnerf::core::Load fromMessage(const dem_nerf::Load& message) {
  demnerf::core::Load load;
  load.name = message.name;
  try {
    load.region = fromMessage(message.region);
  } catch (const Error& error) {
    throw Error("load '" + message.name + "': " + error.what());
  }
  load.force = toEigen(message.wrench.force);
  load.torque = toEigen(message.wrench.torque);
  if (!load.force.allFinite() || !load.torque.allFinite()) {
    throw Error("load '" + message.name + "': wrench holds NaN or Inf");
  }
  return load;
}

dem_nerf::Region toMessage(const demnerf::core::Region& region) {
  dem_nerf::Region message;
  message.pose.position.x = region.center.x();
  message.pose.position.y = region.center.y();
  message.pose.position.z = region.center.z();
  message.pose.orientation.w = 1.0;
  message.size = toVector3(region.size);
  message.radius = region.radius;
  message.normal = toVector3(region.normal);
  switch (region.type) {
    case demnerf::core::Region::Type::kBox: message.type = dem_nerf::Region::BOX; break;
    case demnerf::core::Region::Type::kSphere: message.type = dem_nerf::Region::SPHERE; break;
    case demnerf::core::Region::Type::kHalfspace: message.type = dem_nerf::Region::HALFSPACE; break;
  }
  return message;
}

}  // namespace dem_nerf
