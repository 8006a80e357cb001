#pragma once
// demo_recorder: the end of `make demo`'s ROS run. It keeps what the pipeline publishes (the
// particle cloud nerf_node extracts, the displaced cloud dem_node solves, the model nerf_node
// saves) as files, with the time each arrived, and shuts the launch down once the displaced
// cloud is in (launch files mark it required).

#include <dem_nerf/ModelInfo.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <string>

namespace dem_nerf {

struct DemoRecorderConfig {
  std::string out_dir;   ///< particles.ply, displaced.ply and recorder.json land here (required)
  double timeout = 900;  ///< s: give up (and say which message never came) after this long

  /// Throws demnerf::core::Error naming the first bad parameter.
  static DemoRecorderConfig fromParameters(const ros::NodeHandle& private_node);
};

class DemoRecorder {
 public:
  DemoRecorder(ros::NodeHandle node, ros::NodeHandle private_node, DemoRecorderConfig config);
  /// True once the displaced cloud was written; main's exit status.
  bool complete() const { return complete_; }

 private:
  void onParticles(const sensor_msgs::PointCloud2ConstPtr& message);
  void onModel(const dem_nerf::ModelInfoConstPtr& message);
  void onDisplaced(const sensor_msgs::PointCloud2ConstPtr& message);
  void onTimeout(const ros::WallTimerEvent&);
  void writeSummary(const std::string& outcome) const;
  double sinceStart() const { return (ros::WallTime::now() - start_).toSec(); }

  DemoRecorderConfig config_;
  ros::Subscriber particles_subscriber_, model_subscriber_, displaced_subscriber_;
  ros::WallTimer timeout_timer_;
  ros::WallTime start_;
  double particles_seconds_ = -1, model_seconds_ = -1, displaced_seconds_ = -1;
  std::size_t particle_count_ = 0;
  double max_displacement_ = 0.0;
  dem_nerf::ModelInfo model_;
  bool complete_ = false;
};

}  // namespace dem_nerf
