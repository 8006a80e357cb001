#include <gtest/gtest.h>

#include "demnerf/core/image_preparation.hpp"
#include "demnerf/core/keyframe_selector.hpp"

using namespace demnerf::core;

namespace {

Eigen::Isometry3d poseAt(double x, double yaw_degrees) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().x() = x;
  pose.linear() = Eigen::AngleAxisd(yaw_degrees * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

}  // namespace

TEST(KeyframeSelector, KeepsOnlyViewsThatMovedOrTurned) {
  KeyframeConfig config;
  config.min_translation = 0.1;
  config.min_rotation_degrees = 10.0;
  config.max_frames = 3;
  KeyframeSelector selector(config);
  EXPECT_TRUE(selector.offer(poseAt(0, 0)));
  EXPECT_FALSE(selector.offer(poseAt(0.05, 5)));   // neither far enough nor turned enough
  EXPECT_TRUE(selector.offer(poseAt(0.2, 0)));     // moved
  EXPECT_TRUE(selector.offer(poseAt(0.0, 15)));    // turned
  bool evicted = false;
  EXPECT_TRUE(selector.offer(poseAt(1.0, 0), &evicted));
  EXPECT_TRUE(evicted);
  EXPECT_EQ(selector.size(), 3u);
  Eigen::Isometry3d nan_pose = poseAt(0, 0);
  nan_pose.translation().y() = std::nan("");
  EXPECT_FALSE(selector.offer(nan_pose));
}

TEST(ImagePreparation, FitToSizeScalesIntrinsicsWithTheImage) {
  PinholeCamera camera;
  camera.width = 800;
  camera.height = 400;
  camera.fx = camera.fy = 500;
  camera.cx = 400;
  camera.cy = 200;
  const cv::Mat big(400, 800, CV_32FC4, cv::Scalar::all(0.5));
  const cv::Mat small = fitToSize(big, 200, camera);
  EXPECT_EQ(small.cols, 200);
  EXPECT_EQ(small.rows, 100);
  EXPECT_EQ(camera.width, 200);
  EXPECT_DOUBLE_EQ(camera.fx, 125);
  PinholeCamera unchanged = camera;
  EXPECT_EQ(fitToSize(small, 400, unchanged).cols, 200);
  EXPECT_EQ(unchanged.width, 200);
}

TEST(ImagePreparation, ColourKeyClearsOnlyTheBackdrop) {
  cv::Mat image(2, 2, CV_32FC4, cv::Scalar(0.0, 1.0, 0.0, 1.0));  // green screen
  image.at<cv::Vec4f>(1, 1) = cv::Vec4f(0.8f, 0.2f, 0.1f, 1.0f);   // the object
  image.at<cv::Vec4f>(0, 1) = cv::Vec4f(0.05f, 0.95f, 0.05f, 1.0f); // noisy backdrop
  ColourKey key;
  key.color = cv::Vec3f(0, 1, 0);
  key.tolerance = 0.15;
  applyColourKey(image, key);
  EXPECT_EQ(image.at<cv::Vec4f>(0, 0)[3], 0.0f);
  EXPECT_EQ(image.at<cv::Vec4f>(0, 1)[3], 0.0f);
  EXPECT_EQ(image.at<cv::Vec4f>(1, 1)[3], 1.0f);
}
