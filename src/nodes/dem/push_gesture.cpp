#include "nodes/dem/push_gesture.hpp"

#include <algorithm>
#include <limits>

#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

bool onSurface(const demnerf::core::ParticleCloud& cloud, std::size_t i) {
  return (i < cloud.areas.size() && cloud.areas[i] > 0.0) ||
         (i < cloud.normals.size() && cloud.normals[i].squaredNorm() > 0.0);
}

Eigen::AlignedBox3d bounds(const demnerf::core::ParticleCloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const auto& p : cloud.positions) box.extend(p);
  return box;
}

// The surface particle that maximises score(position) (all particles when none is on the surface).
template <class Score>
SurfacePoint bestSurfacePoint(const demnerf::core::ParticleCloud& cloud, Score score) {
  if (cloud.size() == 0) throw Error("the particle cloud is empty: no surface to push");
  bool any_surface = false;
  for (std::size_t i = 0; i < cloud.size() && !any_surface; ++i) any_surface = onSurface(cloud, i);
  std::size_t best = 0;
  double best_score = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (any_surface && !onSurface(cloud, i)) continue;
    const double s = score(cloud.positions[i]);
    if (s > best_score) {
      best_score = s;
      best = i;
    }
  }
  SurfacePoint point;
  point.position = cloud.positions[best];
  const Eigen::Vector3d normal = best < cloud.normals.size() ? cloud.normals[best] : Eigen::Vector3d::Zero();
  // Without a normal the push points at the body's centre.
  const Eigen::Vector3d inward = normal.squaredNorm() > 0.0 ? Eigen::Vector3d(-normal)
                                                            : Eigen::Vector3d(bounds(cloud).center() - point.position);
  point.inward = inward.squaredNorm() > 0.0 ? inward.normalized() : Eigen::Vector3d::UnitX();
  return point;
}

}  // namespace

PushScales pushScales(const PushConfig& config, const demnerf::core::Material& material,
                      const Eigen::Vector3d& body_size) {
  const double t = std::max(body_size.minCoeff(), 1e-6), length = std::max(body_size.maxCoeff(), 1e-6);
  const double t4 = t * t * t * t;
  PushScales scales;
  scales.force_per_metre =
      config.force_per_metre > 0.0 ? config.force_per_metre : material.youngs_modulus * t4 / (4.0 * length * length * length);
  scales.torque_per_radian =
      config.torque_per_radian > 0.0 ? config.torque_per_radian : material.youngs_modulus * t4 / (20.0 * length);
  return scales;
}

SurfacePoint nearestSurfacePoint(const demnerf::core::ParticleCloud& cloud, const Eigen::Vector3d& point) {
  return bestSurfacePoint(cloud, [&](const Eigen::Vector3d& p) { return -(p - point).squaredNorm(); });
}

SurfacePoint initialPushPoint(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario) {
  if (!scenario.loads.empty()) return nearestSurfacePoint(cloud, scenario.loads.front().region.center);
  const Eigen::Vector3d away_from =
      scenario.fixtures.empty() ? bounds(cloud).center() : scenario.fixtures.front().region.center;
  return bestSurfacePoint(cloud, [&](const Eigen::Vector3d& p) { return (p - away_from).squaredNorm(); });
}

Eigen::Isometry3d restPose(const SurfacePoint& point) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = point.position;
  pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitX(), point.inward).toRotationMatrix();
  return pose;
}

demnerf::core::Load pushLoad(const Eigen::Isometry3d& rest, const Eigen::Isometry3d& dragged, const PushScales& scales,
                             double contact_radius) {
  if (!dragged.matrix().allFinite()) throw Error("the push marker's pose holds NaN or Inf");
  demnerf::core::Load load;
  load.name = "push (interactive marker)";
  load.region.type = demnerf::core::Region::Type::kSphere;
  load.region.center = rest.translation();
  load.region.radius = contact_radius;
  load.force = scales.force_per_metre * (dragged.translation() - rest.translation());
  // The turn from rest to dragged, as a rotation vector in the particles' frame.
  const Eigen::AngleAxisd turn(Eigen::Quaterniond(dragged.linear() * rest.linear().transpose()).normalized());
  load.torque = scales.torque_per_radian * turn.angle() * turn.axis();
  return load;
}

Eigen::Vector3d fixtureBoxSize(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario,
                               const PushConfig& config) {
  if (!scenario.fixtures.empty() && scenario.fixtures.front().region.type == demnerf::core::Region::Type::kBox)
    return scenario.fixtures.front().region.size;
  const double edge = config.fixture_size > 0.0 ? config.fixture_size : 0.2 * bounds(cloud).diagonal().norm();
  return Eigen::Vector3d::Constant(edge);
}

Eigen::Vector3d initialFixtureCenter(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario,
                                     const Eigen::Vector3d& push_point) {
  if (!scenario.fixtures.empty() && scenario.fixtures.front().region.type == demnerf::core::Region::Type::kBox)
    return scenario.fixtures.front().region.center;
  const Eigen::AlignedBox3d box = bounds(cloud);
  Eigen::Index axis = 0;
  box.sizes().maxCoeff(&axis);
  Eigen::Vector3d center = box.center();
  // The face of the longest axis farther from the push point.
  center[axis] = push_point[axis] > center[axis] ? box.min()[axis] : box.max()[axis];
  return center;
}

void placeFixtureBox(demnerf::core::Scenario& scenario, const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  if (!center.allFinite() || !size.allFinite() || !(size.minCoeff() > 0.0))
    throw Error("the fixture box needs a finite centre and positive edge lengths");
  demnerf::core::Fixture fixture;
  fixture.name = "fixture box (interactive marker)";
  fixture.region.type = demnerf::core::Region::Type::kBox;
  fixture.region.center = center;
  fixture.region.size = size;
  if (scenario.fixtures.empty())
    scenario.fixtures.push_back(fixture);
  else
    scenario.fixtures.front() = fixture;
}

}  // namespace dem_nerf
