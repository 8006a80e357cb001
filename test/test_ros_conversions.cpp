// msg <-> core conversions and the dataset bag writer; no ROS master needed.

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <cstring>
#include <filesystem>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/cloud_conversions.hpp"
#include "conversions/dataset_bag.hpp"
#include "conversions/region_conversions.hpp"
#include "demnerf/core/error.hpp"

using demnerf::core::Error;

TEST(Conversions, CameraInfoRoundTrip) {
  demnerf::core::PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 500;
  camera.fy = 510;
  camera.cx = 320.5;
  camera.cy = 240.25;
  camera.k1 = 0.01;
  camera.p2 = -0.002;
  const auto back = dem_nerf::fromCameraInfo(dem_nerf::toCameraInfo(camera, {}));
  EXPECT_EQ(back.width, 640);
  EXPECT_DOUBLE_EQ(back.fy, 510);
  EXPECT_DOUBLE_EQ(back.cy, 240.25);
  EXPECT_DOUBLE_EQ(back.k1, 0.01);
  EXPECT_DOUBLE_EQ(back.p2, -0.002);
  sensor_msgs::CameraInfo fisheye = dem_nerf::toCameraInfo(camera, {});
  fisheye.distortion_model = "equidistant";
  EXPECT_THROW(dem_nerf::fromCameraInfo(fisheye), Error);
  sensor_msgs::CameraInfo empty;
  EXPECT_THROW(dem_nerf::fromCameraInfo(empty), Error);
}

TEST(Conversions, ParticleCloudRoundTripAndBadClouds) {
  demnerf::core::ParticleCloud cloud;
  cloud.resize(2);
  cloud.positions = {{0.1, 0.2, 0.3}, {1, 2, 3}};
  cloud.volumes = {1e-6, 2e-6};
  cloud.normals[1] = {0, 1, 0};
  cloud.areas = {0, 1e-4};
  const auto back = dem_nerf::particlesFromPointCloud2(dem_nerf::toPointCloud2(cloud, {}));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_TRUE(back.positions[1].isApprox(cloud.positions[1], 1e-6));
  EXPECT_NEAR(back.areas[1], 1e-4, 1e-10);
  EXPECT_TRUE(back.normals[1].isApprox(Eigen::Vector3d(0, 1, 0)));

  demnerf::core::ParticleCloud none;
  EXPECT_THROW(dem_nerf::particlesFromPointCloud2(dem_nerf::toPointCloud2(none, {})), Error);
  cloud.positions[0].x() = std::nan("");
  auto message = dem_nerf::toPointCloud2(cloud, {});
  EXPECT_THROW(dem_nerf::particlesFromPointCloud2(message), Error);
}

// Issue 14: a PointCloud2 header that lies about its layout is refused before a byte is read.
TEST(Conversions, CloudLayoutIsCheckedBeforeReading) {
  demnerf::core::ParticleCloud cloud;
  cloud.resize(525);
  std::fill(cloud.volumes.begin(), cloud.volumes.end(), 1e-6);
  const sensor_msgs::PointCloud2 good = dem_nerf::toPointCloud2(cloud, {});
  ASSERT_EQ(dem_nerf::particlesFromPointCloud2(good).size(), 525u);
  const auto refused = [](const sensor_msgs::PointCloud2& message, const std::string& words) {
    try {
      dem_nerf::particlesFromPointCloud2(message, 1000);
      ADD_FAILURE() << "accepted; expected: " << words;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  auto m = good;  // the crash: width 525, point_step 0, empty data
  m.point_step = 0;
  m.row_step = 0;
  m.data.clear();
  refused(m, "point_step 0");
  m = good;
  m.fields[1].offset = 4000000000u;  // y beyond point_step
  refused(m, "does not fit in point_step");
  m = good;
  m.fields[0].datatype = sensor_msgs::PointField::UINT8;  // UINT8 declared on float data
  refused(m, "FLOAT32 (7) or FLOAT64 (8)");
  m = good;
  m.fields[2].datatype = 42;
  refused(m, "unknown datatype 42");
  m = good;
  m.row_step += 4;
  refused(m, "row_step");
  m = good;
  m.data.resize(m.data.size() - 1);
  refused(m, "data holds");
  m = good;
  m.height = 65537;  // width x height x point_step overflows 32 bits
  refused(m, "points, more than the limit");
  m = good;
  m.width = 1 << 20;
  m.height = 1 << 12;  // 2^32 points: rows in 64 bits, not 0 after a wrap
  m.row_step = m.width * m.point_step;
  refused(m, "more than the limit");
  m = good;
  m.is_bigendian = true;
  refused(m, "big-endian");

  // FLOAT64 fields are read as declared.
  sensor_msgs::PointCloud2 wide;
  wide.width = 2;
  wide.height = 1;
  wide.point_step = 24;
  wide.row_step = 48;
  for (const char* name : {"x", "y", "z"}) {
    sensor_msgs::PointField f;
    f.name = name;
    f.offset = static_cast<std::uint32_t>(8 * wide.fields.size());
    f.datatype = sensor_msgs::PointField::FLOAT64;
    f.count = 1;
    wide.fields.push_back(f);
  }
  const double values[6] = {0.5, 1.5, 2.5, -1, -2, -3};
  wide.data.resize(sizeof(values));
  std::memcpy(wide.data.data(), values, sizeof(values));
  const auto back = dem_nerf::particlesFromPointCloud2(wide);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.positions[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(back.positions[0], Eigen::Vector3d(0.5, 1.5, 2.5));
}

TEST(Conversions, RegionsRoundTripAndRejectNan) {
  demnerf::core::Region sphere;
  sphere.type = demnerf::core::Region::Type::kSphere;
  sphere.center = {1, 2, 3};
  sphere.radius = 0.5;
  const auto back = dem_nerf::fromMessage(dem_nerf::toMessage(sphere));
  EXPECT_EQ(back.type, sphere.type);
  EXPECT_DOUBLE_EQ(back.radius, 0.5);
  EXPECT_TRUE(back.center.isApprox(sphere.center));

  dem_nerf::Load load;
  load.name = "grip";
  load.region = dem_nerf::toMessage(sphere);
  load.wrench.force.y = std::nan("");
  try {
    dem_nerf::fromMessage(load);
    FAIL() << "NaN wrench accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("'grip'"), std::string::npos);
  }
  dem_nerf::Fixture fixture;
  fixture.region.type = 7;
  EXPECT_THROW(dem_nerf::fromMessage(fixture), Error);
}

TEST(Conversions, DatasetBagHoldsPosesImagesAndCameraInfos) {
  std::vector<demnerf::core::Frame> frames(3);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frames[i].camera.width = 6;
    frames[i].camera.height = 4;
    frames[i].camera.fx = frames[i].camera.fy = 5;
    frames[i].camera.cx = 3;
    frames[i].camera.cy = 2;
    frames[i].world_from_camera.translation() = Eigen::Vector3d(double(i), 0, 1);
    frames[i].rgba = cv::Mat(4, 6, CV_32FC4, cv::Scalar(0.2, 0.4, 0.6, 1.0));
    frames[i].has_alpha = i == 1;
  }
  const std::string path = (std::filesystem::temp_directory_path() / "demnerf_test.bag").string();
  dem_nerf::DatasetBagOptions options;
  options.rate = 2.0;
  dem_nerf::writeDatasetBag(path, frames, options);

  rosbag::Bag bag(path, rosbag::bagmode::Read);
  std::size_t images = 0, infos = 0, poses = 0;
  for (const rosbag::MessageInstance& message : rosbag::View(bag)) {
    if (auto image = message.instantiate<sensor_msgs::Image>()) {
      EXPECT_EQ(image->encoding, images == 1 ? "rgba8" : "rgb8");
      EXPECT_EQ(image->header.frame_id, dem_nerf::opticalFrameName(options.naming, images));
      EXPECT_EQ(image->data[0], 51);  // 0.2 * 255
      ++images;
    } else if (auto info = message.instantiate<sensor_msgs::CameraInfo>()) {
      EXPECT_DOUBLE_EQ(info->K[2], 3.0);
      ++infos;
    } else if (auto tf = message.instantiate<tf2_msgs::TFMessage>()) {
      ASSERT_EQ(tf->transforms.size(), 3u);
      EXPECT_DOUBLE_EQ(tf->transforms[2].transform.translation.x, 2.0);
      ++poses;
    }
  }
  EXPECT_EQ(images, 3u);
  EXPECT_EQ(infos, 3u);
  EXPECT_EQ(poses, 1u);
  EXPECT_THROW(dem_nerf::writeDatasetBag(path, {}, options), Error);
}
