#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/geometry/regions.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

core::ParticleCloud cubeCloud() {
  SamplerConfig config;
  config.method = SamplingMethod::kGrid;
  config.spacing = 0.1;
  return sampleParticles(testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()), config);
}

TEST(Regions, SelectByBoxSphereAndHalfspace) {
  const auto cloud = cubeCloud();
  core::Region bottom;
  bottom.type = core::Region::Type::kBox;
  bottom.center = Eigen::Vector3d(0.5, 0.5, 0.0);
  bottom.size = Eigen::Vector3d(2.0, 2.0, 0.02);
  const auto base = selectParticles(cloud, bottom, "fixture 'base'", ParticleKind::kSurface);
  EXPECT_EQ(base.size(), 100u);  // the bottom face's crossings
  for (std::size_t i : base) EXPECT_NEAR(cloud.normals[i].z(), -1.0, 1e-12);
  EXPECT_TRUE(std::is_sorted(base.begin(), base.end()));

  core::Region half;
  half.type = core::Region::Type::kHalfspace;
  half.center = Eigen::Vector3d(0.0, 0.0, 0.1);
  half.normal = Eigen::Vector3d::UnitZ();
  EXPECT_EQ(selectParticles(cloud, half, "load 'top'", ParticleKind::kInterior).size(), 100u);  // z = 0.05

  core::Region ball;
  ball.type = core::Region::Type::kSphere;
  ball.center = Eigen::Vector3d::Constant(0.5);
  ball.radius = 0.1;
  EXPECT_EQ(selectParticles(cloud, ball, "probe").size(), 8u);  // the 8 nodes at +-0.05
}

TEST(Regions, EmptyOrNanRegionNamesItself) {
  const auto cloud = cubeCloud();
  core::Region far;
  far.type = core::Region::Type::kSphere;
  far.center = Eigen::Vector3d(5, 5, 5);
  far.radius = 0.1;
  try {
    selectParticles(cloud, far, "fixture 'base'");
    FAIL();
  } catch (const core::Error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("fixture 'base' selects no particles"), std::string::npos) << message;
    EXPECT_NE(message.find("sphere"), std::string::npos) << message;
  }
  far.center.x() = std::nan("");
  EXPECT_THROW(selectParticles(cloud, far, "fixture 'base'"), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
