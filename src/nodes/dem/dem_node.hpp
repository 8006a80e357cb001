#pragma once
// dem_node: takes the particle cloud, fixtures and loads, solves the quasi-static deformation
// and publishes the displaced cloud. All algorithms live in packages/; this class wires ROS.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/Solve.h>
#include <geometry_msgs/WrenchStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <mutex>
#include <optional>
#include <string>

#include "nodes/dem/dem_node_config.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace dem_nerf {

class DemNode {
 public:
  DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config);

 private:
  void onParticles(const sensor_msgs::PointCloud2ConstPtr& message);
  void onFixtures(const dem_nerf::FixtureArrayConstPtr& message);
  void onWrench(const geometry_msgs::WrenchStampedConstPtr& message);
  void onLoadCase(const dem_nerf::LoadCaseConstPtr& message);
  void onModel(const dem_nerf::ModelInfoConstPtr& message);
  bool solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response);

  /// Checks a load case against the current particles; throws core::Error saying what is wrong.
  demnerf::core::Scenario scenarioFor(const dem_nerf::LoadCase& load_case);
  void publishStatus(const std::string& stage, const std::string& message);
  void reportError(const std::string& message);
  void publishPeriodicStatus(const ros::TimerEvent&);

  DemNodeConfig config_;
  ros::Subscriber particles_subscriber_, fixtures_subscriber_, wrench_subscriber_, load_case_subscriber_,
      model_subscriber_;
  ros::Publisher displaced_publisher_, markers_publisher_, status_publisher_;
  image_transport::Publisher rendered_publisher_;
  ros::ServiceServer solve_service_;
  ros::Timer status_timer_;

  std::mutex mutex_;  // guards everything below
  std::optional<demnerf::core::ParticleCloud> particles_;
  demnerf::core::Scenario scenario_;  ///< material and default fixtures/loads from ~scenario
  bool scenario_loaded_ = false;
  std::string last_error_;
};

}  // namespace dem_nerf
