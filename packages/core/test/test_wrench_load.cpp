#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "demnerf/core/error.hpp"
#include "demnerf/core/wrench_load.hpp"

namespace demnerf::core {
namespace {

TEST(WrenchLoad, RotatesForceAndTorqueAndCentresTheSphereAtTheFrameOrigin) {
  // The wrench frame sits at (0.1, 0.2, 0.3), turned 90 degrees about z: its x is the particles' y.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  const Load load = loadFromWrench(pose, Eigen::Vector3d(2.0, 0.0, -1.0), Eigen::Vector3d(0.0, 0.5, 0.0), 0.02,
                                   "wrench in tool");
  EXPECT_EQ(load.name, "wrench in tool");
  EXPECT_EQ(load.region.type, Region::Type::kSphere);
  EXPECT_TRUE(load.region.center.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_DOUBLE_EQ(load.region.radius, 0.02);
  EXPECT_TRUE(load.force.isApprox(Eigen::Vector3d(0.0, 2.0, -1.0), 1e-12)) << load.force.transpose();
  EXPECT_TRUE(load.torque.isApprox(Eigen::Vector3d(-0.5, 0.0, 0.0), 1e-12)) << load.torque.transpose();
  // The sphere selects the particles around the frame's origin, not around the particles' origin.
  EXPECT_TRUE(load.region.contains(Eigen::Vector3d(0.1, 0.2, 0.31)));
  EXPECT_FALSE(load.region.contains(Eigen::Vector3d::Zero()));
}

TEST(WrenchLoad, RefusesNonFiniteWrenchPoseAndRadius) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(loadFromWrench(identity, Eigen::Vector3d(nan, 0, 0), Eigen::Vector3d::Zero(), 0.01, "w"), Error);
  EXPECT_THROW(loadFromWrench(identity, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, INFINITY, 0), 0.01, "w"), Error);
  Eigen::Isometry3d bad = identity;
  bad.translation().x() = nan;
  EXPECT_THROW(loadFromWrench(bad, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero(), 0.01, "w"), Error);
  EXPECT_THROW(loadFromWrench(identity, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero(), nan, "w"), Error);
  EXPECT_THROW(loadFromWrench(identity, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero(), -1.0, "w"), Error);
}

}  // namespace
}  // namespace demnerf::core
