// rostest node: nerf_node turns a replayed dataset into keyframes, posed through tf.

#include <dem_nerf/TrainingStatus.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <atomic>
#include <mutex>

TEST(NerfNodeIntake, ReplayedImagesBecomeKeyframes) {
  ros::NodeHandle node;
  std::atomic<unsigned> frames{0};
  std::mutex mutex;
  dem_nerf::TrainingStatus last;
  auto subscriber = node.subscribe<dem_nerf::TrainingStatus>(
      "/nerf_node/status", 10, [&](const dem_nerf::TrainingStatusConstPtr& status) {
        frames = status->frames;
        std::lock_guard<std::mutex> lock(mutex);
        last = *status;
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(40);
  while (ros::ok() && ros::WallTime::now() < deadline && frames < 10) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_GE(frames.load(), 10u) << last.message;
  EXPECT_EQ(last.intake.rejected, 0u) << last.message;
  EXPECT_EQ(last.intake.tf_missing, 0u) << last.message;
  EXPECT_GE(last.intake.received, last.intake.keyframes) << last.message;
  EXPECT_GT(last.intake.keyframes, 0u) << last.message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nerf_node_intake_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
