// rostest node: what dataset_player publishes matches the dataset on disk, and every image's
// optical frame resolves through tf at the image's stamp.

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <mutex>

#include "demnerf/core/dataset.hpp"

namespace {

struct Received {
  std::mutex mutex;
  std::vector<sensor_msgs::CameraInfo> infos;
  std::vector<sensor_msgs::Image> images;
};

TEST(DatasetPlayer, CameraInfoMatchesTheFileAndTfResolvesAtEachStamp) {
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  std::string data;
  ASSERT_TRUE(private_node.getParam("data", data)) << "~data is not set";
  double downscale = 1.0;
  private_node.param("downscale", downscale, downscale);
  demnerf::core::DatasetOptions options;
  options.load_images = false;
  options.downscale = downscale;
  const demnerf::core::Dataset dataset = demnerf::core::loadDataset(data, options);

  Received received;
  auto info_subscriber = node.subscribe<sensor_msgs::CameraInfo>(
      "camera/camera_info", 10, [&](const sensor_msgs::CameraInfoConstPtr& info) {
        std::lock_guard<std::mutex> lock(received.mutex);
        received.infos.push_back(*info);
      });
  auto image_subscriber = node.subscribe<sensor_msgs::Image>("camera/image_raw", 10, [&](const sensor_msgs::ImageConstPtr& image) {
    std::lock_guard<std::mutex> lock(received.mutex);
    received.images.push_back(*image);
  });
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    std::lock_guard<std::mutex> lock(received.mutex);
    if (received.infos.size() >= 5 && received.images.size() >= 5) break;
    ros::WallDuration(0.02).sleep();
  }
  std::lock_guard<std::mutex> lock(received.mutex);
  ASSERT_GE(received.infos.size(), 5u) << "dataset_player published too few camera_info messages";
  for (const auto& info : received.infos) {
    // Frame index from "<prefix><index>_optical"; the player publishes the train split in order.
    const std::string& frame = info.header.frame_id;
    const auto end = frame.rfind("_optical");
    const auto begin = frame.find_last_not_of("0123456789", end - 1) + 1;
    const std::size_t index = std::stoul(frame.substr(begin, end - begin));
    ASSERT_LT(index, dataset.train.size());
    const demnerf::core::PinholeCamera& camera = dataset.train[index].camera;
    EXPECT_EQ(static_cast<int>(info.width), camera.width);
    EXPECT_EQ(static_cast<int>(info.height), camera.height);
    EXPECT_NEAR(info.K[0], camera.fx, 1e-9);
    EXPECT_NEAR(info.K[4], camera.fy, 1e-9);
    EXPECT_NEAR(info.K[2], camera.cx, 1e-9);
    EXPECT_NEAR(info.D[0], camera.k1, 1e-12);

    std::string error;
    ASSERT_TRUE(buffer.canTransform("world", frame, info.header.stamp, ros::Duration(2.0), &error)) << error;
    const auto transform = buffer.lookupTransform("world", frame, info.header.stamp);
    const Eigen::Vector3d expected = dataset.train[index].world_from_camera.translation();
    EXPECT_NEAR(transform.transform.translation.x, expected.x(), 1e-9);
    EXPECT_NEAR(transform.transform.translation.z, expected.z(), 1e-9);
  }
  for (const auto& image : received.images) {
    EXPECT_TRUE(image.encoding == "rgb8" || image.encoding == "rgba8") << image.encoding;
    EXPECT_EQ(image.step, image.width * (image.encoding == "rgb8" ? 3 : 4));
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dataset_player_check");
  ros::NodeHandle node;  // keeps the node alive across the test
  return RUN_ALL_TESTS();
}
