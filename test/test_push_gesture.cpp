// The interactive push's geometry without ROS: the push marker rests on a surface particle facing
// into the body, its displacement and turn from rest map to force and torque on the patch around
// the rest point, and the fixture box replaces the first fixture.

#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "nodes/dem/push_gesture.hpp"

namespace {

using dem_nerf::PushConfig;
using dem_nerf::PushScales;

// A 0.1 x 0.02 x 0.02 m bar along +x every 5 mm; the outer layer has normals and areas.
demnerf::core::ParticleCloud bar() {
  demnerf::core::ParticleCloud cloud;
  const double h = 0.005;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 4; ++j)
      for (int k = 0; k <= 4; ++k) {
        Eigen::Vector3d normal(i == 0 ? -1 : i == 20 ? 1 : 0, j == 0 ? -1 : j == 4 ? 1 : 0, k == 0 ? -1 : k == 4 ? 1 : 0);
        const bool surface = !normal.isZero();
        cloud.positions.emplace_back(i * h, -0.01 + j * h, -0.01 + k * h);
        cloud.volumes.push_back(h * h * h);
        cloud.normals.push_back(surface ? Eigen::Vector3d(normal.normalized()) : Eigen::Vector3d::Zero());
        cloud.areas.push_back(surface ? h * h : 0.0);
        cloud.colors.push_back({200, 200, 200});
      }
  return cloud;
}

demnerf::core::Scenario clampedAtRoot() {
  demnerf::core::Scenario scenario;
  demnerf::core::Fixture clamp;
  clamp.name = "clamp";
  clamp.region.center = Eigen::Vector3d::Zero();
  clamp.region.size = Eigen::Vector3d(0.01, 0.2, 0.2);
  scenario.fixtures.push_back(clamp);
  return scenario;
}

TEST(PushGesture, TheMarkerStartsOnTheFreeEndFacingIntoTheBody) {
  const auto point = dem_nerf::initialPushPoint(bar(), clampedAtRoot());
  EXPECT_NEAR(point.position.x(), 0.1, 1e-12) << "farthest surface particle from the clamp";
  EXPECT_LT(point.inward.dot(point.position - Eigen::Vector3d(0.05, 0, 0)), 0.0) << "it points into the body";
  const Eigen::Isometry3d rest = dem_nerf::restPose(point);
  EXPECT_TRUE((rest.linear() * Eigen::Vector3d::UnitX()).isApprox(point.inward, 1e-12));
  EXPECT_TRUE(rest.translation().isApprox(point.position));
}

TEST(PushGesture, AMarkerLetGoInsideOrBesideTheBodySnapsToTheNearestSurfaceParticle) {
  const auto cloud = bar();
  const auto inside = dem_nerf::nearestSurfacePoint(cloud, Eigen::Vector3d(0.05, 0.0, 0.004));
  EXPECT_NEAR(inside.position.z(), 0.01, 1e-12) << "the top face is nearest";
  EXPECT_TRUE(inside.inward.isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
  const auto beside = dem_nerf::nearestSurfacePoint(cloud, Eigen::Vector3d(0.05, -0.5, 0.0));
  EXPECT_NEAR(beside.position.y(), -0.01, 1e-12);
  EXPECT_THROW(dem_nerf::nearestSurfacePoint(demnerf::core::ParticleCloud{}, Eigen::Vector3d::Zero()),
               demnerf::core::Error);
}

TEST(PushGesture, DisplacementIsForceAndTurnIsTorqueOnThePatchAroundTheRestPoint) {
  const PushScales scales{200.0, 3.0};
  Eigen::Isometry3d rest = Eigen::Isometry3d::Identity();
  rest.translation() = Eigen::Vector3d(0.1, 0.01, 0.01);
  rest.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Isometry3d dragged = rest;
  dragged.translation() += Eigen::Vector3d(0.0, 0.0, -0.004);
  dragged.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix() * rest.linear();
  const demnerf::core::Load load = dem_nerf::pushLoad(rest, dragged, scales, 0.015);
  EXPECT_TRUE(load.force.isApprox(Eigen::Vector3d(0, 0, -0.8), 1e-12)) << load.force.transpose();
  EXPECT_TRUE(load.torque.isApprox(Eigen::Vector3d(0, 0.6, 0), 1e-9)) << load.torque.transpose();
  EXPECT_EQ(load.region.type, demnerf::core::Region::Type::kSphere);
  EXPECT_TRUE(load.region.center.isApprox(rest.translation()));
  EXPECT_EQ(load.region.radius, 0.015);
  const demnerf::core::Load still = dem_nerf::pushLoad(rest, rest, scales, 0.015);
  EXPECT_TRUE(still.force.isZero() && still.torque.isZero(1e-12)) << "at rest: no load";
  Eigen::Isometry3d broken = rest;
  broken.translation().x() = std::nan("");
  EXPECT_THROW(dem_nerf::pushLoad(rest, broken, scales, 0.015), demnerf::core::Error);
}

TEST(PushGesture, AutomaticStiffnessIsTheBodysCantileverAndTorsionStiffness) {
  demnerf::core::Material material;
  material.youngs_modulus = 1e5;
  const PushScales automatic = dem_nerf::pushScales(PushConfig{}, material, Eigen::Vector3d(0.1, 0.02, 0.02));
  EXPECT_NEAR(automatic.force_per_metre, 1e5 * std::pow(0.02, 4) / (4 * std::pow(0.1, 3)), 1e-12);
  EXPECT_NEAR(automatic.torque_per_radian, 1e5 * std::pow(0.02, 4) / (20 * 0.1), 1e-12);
  PushConfig given;
  given.force_per_metre = 7.0;
  given.torque_per_radian = 0.5;
  const PushScales set = dem_nerf::pushScales(given, material, Eigen::Vector3d(0.1, 0.02, 0.02));
  EXPECT_EQ(set.force_per_metre, 7.0);
  EXPECT_EQ(set.torque_per_radian, 0.5);
}

TEST(PushGesture, TheFixtureBoxStartsOnTheFirstBoxFixtureAndReplacesIt) {
  const auto cloud = bar();
  demnerf::core::Scenario scenario = clampedAtRoot();
  demnerf::core::Fixture roller;
  roller.name = "roller";
  roller.region.center = Eigen::Vector3d(0.05, 0, 0);
  scenario.fixtures.push_back(roller);
  const Eigen::Vector3d size = dem_nerf::fixtureBoxSize(cloud, scenario, PushConfig{});
  EXPECT_TRUE(size.isApprox(Eigen::Vector3d(0.01, 0.2, 0.2)));
  EXPECT_TRUE(dem_nerf::initialFixtureCenter(cloud, scenario, Eigen::Vector3d(0.1, 0, 0)).isZero());
  dem_nerf::placeFixtureBox(scenario, Eigen::Vector3d(0.1, 0, 0), size);
  ASSERT_EQ(scenario.fixtures.size(), 2u);
  EXPECT_TRUE(scenario.fixtures[0].region.center.isApprox(Eigen::Vector3d(0.1, 0, 0)));
  EXPECT_TRUE(scenario.fixtures[0].displacement.isZero());
  EXPECT_EQ(scenario.fixtures[1].name, "roller") << "other fixtures stay";
  // Without fixtures: a cube a fifth of the diagonal, on the face away from the push.
  const demnerf::core::Scenario free_body;
  const Eigen::Vector3d cube = dem_nerf::fixtureBoxSize(cloud, free_body, PushConfig{});
  EXPECT_NEAR(cube.x(), 0.2 * Eigen::Vector3d(0.1, 0.02, 0.02).norm(), 1e-12);
  EXPECT_NEAR(dem_nerf::initialFixtureCenter(cloud, free_body, Eigen::Vector3d(0.1, 0, 0)).x(), 0.0, 1e-12);
  demnerf::core::Scenario none;
  dem_nerf::placeFixtureBox(none, Eigen::Vector3d::Zero(), cube);
  EXPECT_EQ(none.fixtures.size(), 1u);
  EXPECT_THROW(dem_nerf::placeFixtureBox(none, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), demnerf::core::Error);
}

}  // namespace
