#include <ros/ros.h>

#include "nodes/nerf/nerf_node.hpp"
#include "runtime/configure_runtime.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "nerf_node");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  try {
    const dem_nerf::NerfNodeConfig config = dem_nerf::NerfNodeConfig::fromParameters(private_node);
    dem_nerf::configureRuntime({config.nerf.train.threads, false});
    dem_nerf::NerfNode nerf_node(node, private_node, config);
    ros::AsyncSpinner spinner(2);  // services stay responsive while images arrive
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::exception& error) {
    ROS_FATAL("nerf_node: %s", error.what());
    return 1;
  }
  return 0;
}
