// rostest node: nerf_node turns a replayed dataset into keyframes, posed through tf.

#include <dem_nerf/TrainingStatus.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <atomic>

TEST(NerfNodeIntake, ReplayedImagesBecomeKeyframes) {
  ros::NodeHandle node;
  std::atomic<unsigned> frames{0};
  std::string last_message;
  auto subscriber = node.subscribe<dem_nerf::TrainingStatus>(
      "/nerf_node/status", 10, [&](const dem_nerf::TrainingStatusConstPtr& status) {
        frames = status->frames;
        last_message = status->message;
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(40);
  while (ros::ok() && ros::WallTime::now() < deadline && frames < 10) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  EXPECT_GE(frames.load(), 10u) << last_message;
  EXPECT_NE(last_message.find(" 0 rejected"), std::string::npos) << last_message;
  EXPECT_NE(last_message.find(" 0 without tf"), std::string::npos) << last_message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nerf_node_intake_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
