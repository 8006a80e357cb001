#pragma once
// The nodes' fuzz check's fixture (nodes_fuzz_check.cpp): publishers to both nodes, the good state
// to return to after each batch, and the liveness check; rejection counters read from ~status.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/RenderView.h>
#include <dem_nerf/Solve.h>
#include <dem_nerf/TrainingStatus.h>
#include <geometry_msgs/WrenchStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <memory>
#include <string>

#include "check_helpers.hpp"
#include "fuzz_messages.hpp"

namespace dem_nerf_fuzz {

using dem_nerf_test::StatusRecorder;

inline std::uint32_t rejectionsOf(const dem_nerf::TrainingStatus& status, const std::string& cause) {
  for (const auto& item : status.rejections)
    if (item.cause == cause) return item.count;
  return 0;
}
inline std::uint32_t rejectionTotal(const dem_nerf::TrainingStatus& status) {
  std::uint32_t total = 0;
  for (const auto& item : status.rejections) total += item.count;
  return total;
}

class NodesFuzz : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(ros::service::waitForService("/dem_node/solve", ros::Duration(30)));
    ASSERT_TRUE(ros::service::waitForService("/nerf_node/render", ros::Duration(30)));
  }

  void SetUp() override {
    tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    dem_nerf_test::broadcastToolFrame(*tf_);
    geometry_msgs::TransformStamped camera;
    camera.header.stamp = ros::Time(0);
    camera.header.frame_id = "world";
    camera.child_frame_id = "camera_optical";
    camera.transform.translation.z = 0.5;
    camera.transform.rotation.w = 1.0;
    tf_->sendTransform(camera);
    particles_ = node_.advertise<sensor_msgs::PointCloud2>("/particles", 1, true);
    fixtures_ = node_.advertise<dem_nerf::FixtureArray>("/dem_node/fixtures", 10);
    wrench_ = node_.advertise<geometry_msgs::WrenchStamped>("/dem_node/wrench", 10);
    load_case_ = node_.advertise<dem_nerf::LoadCase>("/dem_node/load_case", 10);
    model_ = node_.advertise<dem_nerf::ModelInfo>("/model", 10);
    render_info_ = node_.advertise<sensor_msgs::CameraInfo>("/dem_node/render_camera_info", 10);
    images_ = node_.advertise<sensor_msgs::Image>("/camera/image_raw", 10);
    infos_ = node_.advertise<sensor_msgs::CameraInfo>("/camera/camera_info", 10);
    ASSERT_TRUE(dem_nerf_test::spinUntil(
        [&] {
          return particles_.getNumSubscribers() > 0 && fixtures_.getNumSubscribers() > 0 &&
                 wrench_.getNumSubscribers() > 0 && load_case_.getNumSubscribers() > 0 &&
                 images_.getNumSubscribers() > 0 && infos_.getNumSubscribers() > 0 &&
                 render_info_.getNumSubscribers() > 0 && model_.getNumSubscribers() > 0;
        },
        20));
    restoreGoodState();
  }

  /// The bar and the clamp again (a valid mutant may have replaced them), until a solve sees them.
  void restoreGoodState() {
    particles_.publish(barCloud());
    dem_nerf::FixtureArray clamp;
    clamp.header.frame_id = "world";
    clamp.fixtures = {clampFixture()};
    fixtures_.publish(clamp);
    ASSERT_TRUE(dem_nerf_test::spinUntil([&] { return goodSolve(false); }, 30)) << "dem_node lost the bar";
  }

  /// A good ~solve answers with the bar, displaced.
  bool goodSolve(bool report = true) {
    dem_nerf::Solve solve;
    solve.request.load_case = goodLoadCase();
    if (!ros::service::call("/dem_node/solve", solve)) {
      if (report) ADD_FAILURE() << "dem_node's ~solve did not answer (is the node dead?)";
      return false;
    }
    const bool ok = solve.response.ok &&
                    solve.response.displaced.width * solve.response.displaced.height ==
                        dem_nerf_test::barParticles().size() &&
                    solve.response.max_displacement > 0;
    if (report) EXPECT_TRUE(ok) << solve.response.message;
    return ok;
  }

  /// Both nodes alive: dem_node solves a good request; nerf_node answers ~render and ~save with
  /// their clear "no model yet" reasons; both keep publishing ~status.
  void expectBothAlive(const std::string& after) {
    SCOPED_TRACE("after " + after);
    restoreGoodState();
    EXPECT_TRUE(goodSolve());
    dem_nerf::RenderView render;
    render.request.camera_info = cameraInfo(8, 6);
    render.request.pose.orientation.w = 1.0;
    ASSERT_TRUE(ros::service::call("/nerf_node/render", render)) << "nerf_node's ~render did not answer";
    EXPECT_NE(render.response.message, "");
    dem_nerf::SaveModel save;
    ASSERT_TRUE(ros::service::call("/nerf_node/save", save)) << "nerf_node's ~save did not answer";
    EXPECT_NE(save.response.message.find("nothing to save"), std::string::npos) << save.response.message;
    StatusRecorder dem(node_, "/dem_node/status"), nerf(node_, "/nerf_node/status");
    dem.mark();
    nerf.mark();
    const auto any = [](const dem_nerf::TrainingStatus&) { return true; };
    EXPECT_TRUE(dem.waitUntil(any, 5)) << "no ~status from dem_node";
    EXPECT_TRUE(nerf.waitUntil(any, 5)) << "no ~status from nerf_node";
  }

  /// The latest ~status of a node.
  dem_nerf::TrainingStatus latestStatus(const std::string& node) {
    StatusRecorder recorder(node_, "/" + node + "/status");
    recorder.mark();
    dem_nerf::TrainingStatus status;
    EXPECT_TRUE(recorder.waitUntil([](const dem_nerf::TrainingStatus&) { return true; }, 5, &status));
    return status;
  }

  template <typename Message>
  void publishPaced(ros::Publisher& publisher, const Message& message) {
    publisher.publish(message);
    ros::WallDuration(0.004).sleep();
  }

  void publishImagePair(sensor_msgs::Image image, sensor_msgs::CameraInfo info) {
    image.header.stamp = info.header.stamp = ros::Time::now();
    info.header.frame_id = image.header.frame_id;
    images_.publish(image);
    infos_.publish(info);
    ros::WallDuration(0.01).sleep();
  }

  ros::NodeHandle node_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_;
  ros::Publisher particles_, fixtures_, wrench_, load_case_, model_, render_info_, images_, infos_;
};

}  // namespace dem_nerf_fuzz
