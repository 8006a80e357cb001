#include <ros/ros.h>

#include "demnerf/core/error.hpp"
#include "nodes/recorder/demo_recorder.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "demo_recorder");
  ros::NodeHandle node, private_node("~");
  try {
    dem_nerf::DemoRecorder recorder(node, private_node, dem_nerf::DemoRecorderConfig::fromParameters(private_node));
    ros::spin();
    return recorder.complete() ? 0 : 1;
  } catch (const demnerf::core::Error& e) {
    ROS_FATAL("demo_recorder: %s", e.what());
    return 2;
  }
}
