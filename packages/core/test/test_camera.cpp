#include <gtest/gtest.h>

#include "demnerf/core/camera.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/pose.hpp"
#include "demnerf/core/ray.hpp"

using namespace demnerf::core;

namespace {

PinholeCamera foxLikeCamera() {
  PinholeCamera camera;
  camera.width = 1080;
  camera.height = 1920;
  camera.fx = 1375.5;
  camera.fy = 1374.3;
  camera.cx = 541.1;
  camera.cy = 958.2;
  camera.k1 = 0.0067;
  camera.k2 = -0.0104;
  camera.p1 = 0.0011;
  camera.p2 = -0.0006;
  return camera;
}

}  // namespace

TEST(Camera, ProjectThenUnprojectReturnsTheSameRayWithDistortion) {
  const PinholeCamera camera = foxLikeCamera();
  for (double u : {3.0, 200.5, 540.0, 1077.0}) {
    for (double v : {2.0, 960.0, 1915.5}) {
      const Eigen::Vector3d direction = camera.unproject({u, v});
      EXPECT_NEAR(direction.norm(), 1.0, 1e-12);
      const Eigen::Vector2d pixel = camera.project(direction * 3.7);
      EXPECT_NEAR(pixel.x(), u, 1e-6);
      EXPECT_NEAR(pixel.y(), v, 1e-6);
    }
  }
}

TEST(Camera, WorldPointProjectsOntoThePixelWhoseRayPassesThroughIt) {
  const PinholeCamera camera = foxLikeCamera();
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  world_from_camera.translation() = Eigen::Vector3d(0.3, -1.2, 2.0);
  const Eigen::Vector3d point_in_world = world_from_camera * Eigen::Vector3d(0.2, -0.4, 2.5);
  const Eigen::Vector2d pixel = camera.project(world_from_camera.inverse() * point_in_world);
  const Ray ray = generateRay(camera, world_from_camera, pixel);
  const Eigen::Vector3d to_point = point_in_world - ray.origin;
  EXPECT_NEAR((to_point - to_point.dot(ray.direction) * ray.direction).norm(), 0.0, 1e-9);
  EXPECT_GT(to_point.dot(ray.direction), 0.0);
}

TEST(Camera, PixelRaysCoverTheImageRowMajor) {
  PinholeCamera camera;
  camera.width = 4;
  camera.height = 3;
  camera.fx = camera.fy = 2.0;
  camera.cx = 2.0;
  camera.cy = 1.5;
  const auto rays = generatePixelRays(camera, Eigen::Isometry3d::Identity());
  ASSERT_EQ(rays.size(), 12u);
  EXPECT_LT(rays[0].direction.x(), 0.0);   // top-left pixel looks left...
  EXPECT_LT(rays[0].direction.y(), 0.0);   // ...and up (optical y points down)
  EXPECT_GT(rays[11].direction.x(), 0.0);
  EXPECT_GT(rays[11].direction.y(), 0.0);
}

TEST(Camera, DownscaleKeepsTheFieldOfView) {
  const PinholeCamera camera = foxLikeCamera();
  const PinholeCamera small = camera.downscaled(4.0);
  EXPECT_EQ(small.width, 270);
  EXPECT_EQ(small.height, 480);
  EXPECT_NEAR(small.width / small.fx, camera.width / camera.fx, 1e-9);
  EXPECT_THROW(camera.downscaled(0.0), Error);
}

TEST(Camera, InvalidIntrinsicsAreNamed) {
  PinholeCamera camera = foxLikeCamera();
  camera.fx = -1;
  try {
    camera.validate();
    FAIL() << "negative focal length accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("focal"), std::string::npos);
  }
}

TEST(Pose, OpenGlAndOpticalFramesLookTheSameWay) {
  Eigen::Isometry3d gl = Eigen::Isometry3d::Identity();
  gl.translation() = Eigen::Vector3d(0, 0, 4);  // OpenGL camera at +z looking down -z to the origin
  const Eigen::Isometry3d optical = openGlToOptical(gl);
  EXPECT_TRUE(optical.linear().col(2).isApprox(Eigen::Vector3d(0, 0, -1)));  // optical z forward
  EXPECT_TRUE(optical.linear().col(1).isApprox(Eigen::Vector3d(0, -1, 0)));  // optical y down
  EXPECT_TRUE(opticalToOpenGl(optical).isApprox(gl));
}

TEST(Pose, RigidTransformChecks) {
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  EXPECT_TRUE(isRigidTransform(matrix));
  matrix(0, 0) = 2.0;
  EXPECT_FALSE(isRigidTransform(matrix));
  matrix(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(isRigidTransform(matrix));
}
