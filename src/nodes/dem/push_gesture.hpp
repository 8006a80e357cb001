#pragma once
// The interactive push's geometry, without ROS: where the push marker rests on the body, how its
// displacement and rotation from that rest pose become a force and a torque on the particles
// within the contact radius, and how the fixture box becomes a fixture. interactive_push.hpp
// wires these to an interactive marker server.

#include <Eigen/Geometry>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace dem_nerf {

/// dem_node's ~push_* parameters (read with ~interactive in interactive_push.cpp).
struct PushConfig {
  /// N per metre the push marker is dragged from its rest pose. 0: E t^4 / (4 L^3) with t and L
  /// the smallest and largest edge of the body's bounding box: a cantilever's tip stiffness, so
  /// that a slender body's free end roughly follows the drag (and a compact one, t = L, about the
  /// stiffness of pressing on it: E L / 4).
  double force_per_metre = 0.0;
  /// N m per radian the push marker is turned. 0: E t^4 / (20 L), a square bar's torsional
  /// stiffness (G J / L with G = E / 2.6, J = 0.14 t^4), by the same reasoning.
  double torque_per_radian = 0.0;
  /// m edge of the fixture box when the scenario's first fixture is no box; 0: a fifth of the
  /// body's bounding-box diagonal.
  double fixture_size = 0.0;
};

/// The stiffnesses in force: the configured ones, or the automatic ones from the material and the
/// body's bounding-box edges.
struct PushScales {
  double force_per_metre = 0.0;
  double torque_per_radian = 0.0;
};
PushScales pushScales(const PushConfig& config, const demnerf::core::Material& material,
                      const Eigen::Vector3d& body_size);

/// A surface particle and the direction into the body there (its normal reversed).
struct SurfacePoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d inward = Eigen::Vector3d::UnitX();
};

/// The surface particle (area > 0 or a normal) nearest to `point`; every particle counts when
/// none is marked as surface. core::Error for an empty cloud.
SurfacePoint nearestSurfacePoint(const demnerf::core::ParticleCloud& cloud, const Eigen::Vector3d& point);

/// Where the push marker starts: at the scenario's first load if it has one; otherwise at the
/// surface particle farthest from the first fixture (a cantilever's free end), or from the body's
/// centre without fixtures.
SurfacePoint initialPushPoint(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario);

/// The marker's rest pose on a surface point: there, its x axis pointing into the body.
Eigen::Isometry3d restPose(const SurfacePoint& point);

/// The load of the marker dragged from `rest` to `dragged`: force = force_per_metre x (dragged
/// position - rest position), torque = torque_per_radian x the rotation vector of dragged's
/// orientation relative to rest's (both in the particles' frame), acting on the particles within
/// contact_radius of the rest position (the patch).
demnerf::core::Load pushLoad(const Eigen::Isometry3d& rest, const Eigen::Isometry3d& dragged, const PushScales& scales,
                             double contact_radius);

/// The fixture box's edge lengths: the scenario's first fixture's when it is a box, else a cube of
/// config.fixture_size (or a fifth of the body's bounding-box diagonal).
Eigen::Vector3d fixtureBoxSize(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario,
                               const PushConfig& config);
/// Where the fixture box starts: on the scenario's first fixture when it is a box, else centred on
/// the body's face opposite the push point (along the bounding box's longest axis).
Eigen::Vector3d initialFixtureCenter(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario,
                                     const Eigen::Vector3d& push_point);

/// The scenario with a clamp (all components held at zero) in the box at `center`: it replaces
/// the first fixture, or is the only one when there was none; other fixtures stay.
void placeFixtureBox(demnerf::core::Scenario& scenario, const Eigen::Vector3d& center, const Eigen::Vector3d& size);

}  // namespace dem_nerf
