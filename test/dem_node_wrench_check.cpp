// rostest node: dem_node turns a cantilever's particles, its clamp and a wrench resolved through tf
// into a displaced cloud: the tip follows the force and the clamped particles stay put.

#include <dem_nerf/TrainingStatus.h>
#include <geometry_msgs/WrenchStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <mutex>
#include <optional>

#include "check_helpers.hpp"
#include "conversions/cloud_conversions.hpp"

namespace {

/// ~export_dir: the solve was also written as <export_dir>/solve_0001.vtu, a VTK XML grid of
/// every particle (test_vtk_export reads such files back with VTK and checks their numbers).
void expectExported(std::size_t particles, std::filesystem::file_time_type started) {
  std::string folder;
  ASSERT_TRUE(ros::param::get("/dem_node/export_dir", folder));
  const std::filesystem::path file = std::filesystem::path(folder) / "solve_0001.vtu";
  // The file is written right after the cloud is published.
  for (int i = 0; i < 100 && !std::filesystem::exists(file); ++i) ros::WallDuration(0.05).sleep();
  ASSERT_TRUE(std::filesystem::exists(file)) << file;
  EXPECT_GE(std::filesystem::last_write_time(file), started) << "a stale file from an earlier run";
  std::ifstream in(file);
  const std::string head((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(head.find("<VTKFile type=\"UnstructuredGrid\""), std::string::npos);
  EXPECT_NE(head.find("NumberOfPoints=\"" + std::to_string(particles) + "\""), std::string::npos);
  for (const char* name : {"Name=\"displacement\"", "Name=\"von_mises\"", "Name=\"volume\""})
    EXPECT_NE(head.find(name), std::string::npos) << name;
}

TEST(DemNodeWrench, TheTipFollowsTheForceAndTheClampHolds) {
  const auto started = std::filesystem::file_time_type::clock::now() - std::chrono::seconds(1);
  ros::NodeHandle node;
  std::mutex mutex;
  std::optional<sensor_msgs::PointCloud2> displaced;
  auto subscriber = node.subscribe<sensor_msgs::PointCloud2>(
      "/dem_node/displaced", 1, [&](const sensor_msgs::PointCloud2ConstPtr& message) {
        std::lock_guard<std::mutex> lock(mutex);
        displaced = *message;
      });
  tf2_ros::StaticTransformBroadcaster broadcaster;
  dem_nerf_test::broadcastToolFrame(broadcaster);
  const demnerf::core::ParticleCloud bar = dem_nerf_test::barParticles(0.005);
  dem_nerf_test::StatusRecorder status(node, "/dem_node/status");
  ros::Publisher particles = dem_nerf_test::publishParticles(node, bar);
  ros::Publisher wrenches = node.advertise<geometry_msgs::WrenchStamped>("/dem_node/wrench", 1, true);
  // The wrench must come after the particles (the scenario has no loads, so the particles alone
  // solve nothing): wait until ~status says the node holds them, not a fixed time.
  ASSERT_TRUE(status.waitUntil([&](const dem_nerf::TrainingStatus& s) { return s.particles == bar.size(); }, 30))
      << "dem_node did not take the particles";
  geometry_msgs::WrenchStamped wrench;
  wrench.header.frame_id = "tool";
  wrench.header.stamp = ros::Time(0);  // latest tf
  wrench.wrench.force.z = -0.002;  // small: a few mm, where the tip moves along the force
  {
    std::lock_guard<std::mutex> lock(mutex);
    displaced.reset();  // only the answer to this wrench counts
  }
  wrenches.publish(wrench);

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(60);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (displaced) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(displaced.has_value()) << "no displaced cloud within 60 s";
  ASSERT_EQ(static_cast<std::size_t>(displaced->width) * displaced->height, bar.size());
  sensor_msgs::PointCloud2ConstIterator<float> u(*displaced, "ux");
  double tip_uz = 0.0, tip_lateral = 0.0, clamp_max = 0.0;
  int tip_count = 0;
  for (std::size_t i = 0; i < bar.size(); ++i, ++u) {
    const Eigen::Vector3d displacement(u[0], u[1], u[2]);
    if (bar.positions[i].x() < 1e-9) clamp_max = std::max(clamp_max, displacement.norm());
    if (bar.positions[i].x() > 0.1 - 1e-9) {
      tip_uz += displacement.z();
      tip_lateral += std::abs(displacement.x()) + std::abs(displacement.y());
      ++tip_count;
    }
  }
  tip_uz /= tip_count;
  tip_lateral /= tip_count;
  EXPECT_LT(tip_uz, -1e-5) << "the tip should move down with the -z force";
  std::printf("cantilever tip: uz %.3g m, mean |ux|+|uy| %.3g m\n", tip_uz, tip_lateral);
  EXPECT_LT(tip_lateral, 0.3 * std::abs(tip_uz));
  EXPECT_LT(clamp_max, 1e-6) << "clamped particles moved";
  expectExported(bar.size(), started);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dem_node_wrench_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
