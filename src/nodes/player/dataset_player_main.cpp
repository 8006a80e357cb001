#include <ros/ros.h>

#include "nodes/player/dataset_player.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "dataset_player");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  try {
    dem_nerf::DatasetPlayer player(node, dem_nerf::DatasetPlayerConfig::fromParameters(private_node));
    ros::spin();
  } catch (const std::exception& error) {
    ROS_FATAL("dataset_player: %s", error.what());
    return 1;
  }
  return 0;
}
