#pragma once
// dem_node: takes the particle cloud, fixtures and loads, solves the quasi-static deformation
// in a worker thread and publishes the displaced cloud. All algorithms live in packages/; this
// class only wires them to ROS.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/Solve.h>
#include <geometry_msgs/WrenchStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "nodes/dem/dem_node_config.hpp"
#include "workers/latest_wins_worker.hpp"

namespace dem_nerf {

class DemNode {
 public:
  DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config);

 private:
  /// What one solve needs; a newer one replaces a waiting one (bursts coalesce).
  struct SolveJob {
    demnerf::core::ParticleCloud cloud;
    demnerf::core::Scenario scenario;
    std::string cause;  ///< "wrench", "load case", ... for the status message
  };

  void onParticles(const sensor_msgs::PointCloud2ConstPtr& message);
  void onFixtures(const dem_nerf::FixtureArrayConstPtr& message);
  void onWrench(const geometry_msgs::WrenchStampedConstPtr& message);
  void onLoadCase(const dem_nerf::LoadCaseConstPtr& message);
  void onModel(const dem_nerf::ModelInfoConstPtr& message);
  bool solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response);

  /// The current scenario with a load case's fixtures and loads; throws core::Error saying what
  /// is wrong (no material, no particles, a region that selects nothing, NaN).
  demnerf::core::Scenario scenarioFor(const dem_nerf::LoadCase& load_case);
  /// Queues a solve of the current state when particles and a scenario are there.
  void requestSolve(const std::string& cause);
  void runSolve(const SolveJob& job);
  void publishResult(const demnerf::mechanics::SimulationOutcome& outcome, const demnerf::core::Scenario& scenario);
  void publishStatus(const std::string& stage, const std::string& message);
  void reportError(const std::string& message);
  void publishPeriodicStatus(const ros::TimerEvent&);

  DemNodeConfig config_;
  demnerf::mechanics::SolverChoice solver_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber particles_subscriber_, fixtures_subscriber_, wrench_subscriber_, load_case_subscriber_,
      model_subscriber_;
  ros::Publisher displaced_publisher_, markers_publisher_, status_publisher_;
  image_transport::Publisher rendered_publisher_;
  ros::ServiceServer solve_service_;
  ros::Timer status_timer_;

  std::mutex mutex_;  // guards everything below
  std::optional<demnerf::core::ParticleCloud> particles_;
  demnerf::core::Scenario scenario_;  ///< material and current fixtures/loads
  bool scenario_loaded_ = false;
  std::string stage_ = "idle";
  std::string last_error_;
  std::string last_figures_;

  std::unique_ptr<LatestWinsWorker<SolveJob>> worker_;  // last: its thread uses the members above
};

}  // namespace dem_nerf
