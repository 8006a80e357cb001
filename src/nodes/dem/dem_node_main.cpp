#include <ros/ros.h>

#include "nodes/dem/dem_node.hpp"
#include "runtime/configure_runtime.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "dem_node");
  ros::NodeHandle node;
  ros::NodeHandle private_node("~");
  try {
    const dem_nerf::DemNodeConfig config = dem_nerf::DemNodeConfig::fromParameters(private_node);
    const demnerf::mechanics::DemConfig& dem = config.solver_options.dem;
    // OpenBLAS's idle workers may be ended during a solve: the render worker marks its renders
    // (BlasCallsInFlight), the only BLAS calls beside the solve worker's.
    dem_nerf::configureRuntime({dem.threads, dem.tune_allocator, true});
    dem_nerf::DemNode dem_node(node, private_node, config);
    ros::AsyncSpinner spinner(2);
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::exception& error) {
    ROS_FATAL("dem_node: %s", error.what());
    return 1;
  }
  return 0;
}
