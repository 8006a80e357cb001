// The scenario files of config/scenarios select the intended parts of the synthetic scenes'
// meshes, and their loads give the intended twist.
#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/scenario.hpp"
#include "demnerf/render/scene_geometry.hpp"

namespace demnerf::render {
namespace {

core::Scenario load(const std::string& name) {
  return core::loadScenario(std::string(DEMNERF_SOURCE_DIR) + "/config/scenarios/" + name);
}

std::vector<Eigen::Vector3d> selected(const core::Region& region, const core::TriangleMesh& mesh) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& v : mesh.vertices) {
    if (region.contains(v)) points.push_back(v);
  }
  return points;
}

Eigen::Vector3d centroid(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

TEST(Scenarios, TBarTwistFixesTheBaseAndTwistsTheBarByAbout20Degrees) {
  const core::Scenario scenario = load("tbar_twist.yaml");
  const SceneObject tbar = makeSceneObject(SceneKind::kTBar);
  ASSERT_EQ(scenario.fixtures.size(), 1u);
  const auto base = selected(scenario.fixtures[0].region, tbar.mesh);
  ASSERT_FALSE(base.empty());
  for (const auto& p : base) EXPECT_LE(p.z(), 0.005 + 1e-12);
  ASSERT_EQ(scenario.loads.size(), 2u);
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  for (const auto& load : scenario.loads) {
    const auto patch = selected(load.region, tbar.mesh);
    ASSERT_FALSE(patch.empty()) << load.name;
    for (const auto& p : patch) EXPECT_GE(p.z(), 0.24 - 1e-12) << load.name << " reaches below the bar";
    force += load.force;
    torque += centroid(patch).cross(load.force) + load.torque;
  }
  EXPECT_LT(force.norm(), 1e-12) << "a pure couple";
  EXPECT_NEAR(torque.x(), 0.0, 1e-9);
  EXPECT_NEAR(torque.y(), 0.0, 0.02 * torque.z());  // the forces act at the same height
  // Square-section torsion of the leg: theta = T L / (G 0.141 a^4).
  const double a = 0.06, length = 0.24;
  const double theta = torque.z() * length / (scenario.material.mu() * 0.141 * std::pow(a, 4));
  const double degrees = theta * 180.0 / M_PI;
  EXPECT_GT(degrees, 15.0);
  EXPECT_LT(degrees, 30.0);
}

TEST(Scenarios, CuboidTwistHoldsOneEndAndTwistsTheOther) {
  const core::Scenario scenario = load("cuboid_twist.yaml");
  const SceneObject cuboid = makeSceneObject(SceneKind::kCuboid);
  ASSERT_EQ(scenario.fixtures.size(), 1u);
  ASSERT_EQ(scenario.loads.size(), 1u);
  for (const auto& p : selected(scenario.fixtures[0].region, cuboid.mesh)) EXPECT_LE(p.x(), 0.005 + 1e-12);
  const auto end = selected(scenario.loads[0].region, cuboid.mesh);
  ASSERT_FALSE(end.empty());
  for (const auto& p : end) EXPECT_GE(p.x(), 0.12 - 1e-12);
  EXPECT_GT(scenario.loads[0].torque.x(), 0.0);
  const double theta = scenario.loads[0].torque.x() * 0.125 / (scenario.material.mu() * 0.141 * 1e-4);
  EXPECT_GT(theta * 180.0 / M_PI, 15.0);
  EXPECT_LT(theta * 180.0 / M_PI, 30.0);
}

TEST(Scenarios, CookMembraneIsTheDealIiReference) {
  const core::Scenario scenario = load("cook_membrane.yaml");
  const SceneObject cook = makeSceneObject(SceneKind::kCookMembrane);
  EXPECT_EQ(scenario.material.model, "neo_hookean_decoupled");
  EXPECT_NEAR(scenario.material.mu(), 422.5e3, 1.0);
  EXPECT_DOUBLE_EQ(scenario.material.poisson_ratio, 0.3);
  EXPECT_EQ(scenario.load_steps, 10);
  ASSERT_EQ(scenario.fixtures.size(), 3u);
  // The clamp holds the whole left edge (x = 0, y 0..44 mm), nothing else.
  const auto clamp = selected(scenario.fixtures[0].region, cook.mesh);
  EXPECT_EQ(scenario.fixtures[0].constrained, Eigen::Vector3i(1, 1, 1));
  std::size_t left_edge = 0;
  for (const auto& v : cook.mesh.vertices) left_edge += v.x() < 1e-12 ? 1 : 0;
  EXPECT_EQ(clamp.size(), left_edge);
  // Plane strain: u_z only, on both z faces, which together hold every vertex of this slab.
  std::size_t on_faces = 0;
  for (int f = 1; f <= 2; ++f) {
    EXPECT_EQ(scenario.fixtures[f].constrained, Eigen::Vector3i(0, 0, 1));
    on_faces += selected(scenario.fixtures[f].region, cook.mesh).size();
  }
  EXPECT_EQ(on_faces, cook.mesh.vertices.size());
  // 1 N in +y on the right edge (x = 48 mm, y 44..60 mm), every vertex of it.
  ASSERT_EQ(scenario.loads.size(), 1u);
  EXPECT_TRUE(scenario.loads[0].force.isApprox(Eigen::Vector3d(0, 1, 0)));
  const auto edge = selected(scenario.loads[0].region, cook.mesh);
  std::size_t right_edge = 0;
  for (const auto& v : cook.mesh.vertices) right_edge += v.x() > 0.048 - 1e-12 ? 1 : 0;
  EXPECT_EQ(edge.size(), right_edge);
}

}  // namespace
}  // namespace demnerf::render
