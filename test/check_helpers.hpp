#pragma once
// Shared by the rostest checks of the nodes: a ~status recorder, waiting for a latched message, a
// small bar of particles with a clamped end, the tool frame its wrenches come in, half-spaces.

#include <dem_nerf/Region.h>
#include <dem_nerf/TrainingStatus.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "conversions/cloud_conversions.hpp"
#include "demnerf/core/ply.hpp"

namespace dem_nerf_test {

/// Records every TrainingStatus of one topic.
class StatusRecorder {
 public:
  StatusRecorder(ros::NodeHandle& node, const std::string& topic)
      : subscriber_(node.subscribe(topic, 100, &StatusRecorder::onStatus, this)) {
    // Statuses published before the connection stands would be missed.
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10);
    while (ros::ok() && subscriber_.getNumPublishers() == 0 && ros::WallTime::now() < deadline) {
      ros::WallDuration(0.02).sleep();
    }
  }

  /// Waits until a status whose stage is `stage` (any stage when empty) and whose message holds
  /// `text` arrives after the mark; returns its message, or "" on timeout.
  std::string waitFor(const std::string& stage, const std::string& text, double seconds) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      ros::spinOnce();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (std::size_t i = mark_; i < received_.size(); ++i) {
          const auto& status = received_[i];
          if ((stage.empty() || status.stage == stage) && status.message.find(text) != std::string::npos) {
            return status.message;
          }
        }
      }
      ros::WallDuration(0.02).sleep();
    }
    return "";
  }
  std::string waitForError(const std::string& text, double seconds) { return waitFor("error", text, seconds); }

  /// Waits for a status that satisfies `accept`; returns whether one came.
  bool waitUntil(const std::function<bool(const dem_nerf::TrainingStatus&)>& accept, double seconds,
                 dem_nerf::TrainingStatus* found = nullptr) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      ros::spinOnce();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (std::size_t i = mark_; i < received_.size(); ++i) {
          if (accept(received_[i])) {
            if (found != nullptr) *found = received_[i];
            return true;
          }
        }
      }
      ros::WallDuration(0.02).sleep();
    }
    return false;
  }

  /// dem_node: waits for a solve answered after the mark whose cause holds `cause` (~status's
  /// last_solve, whose sequence grows with each answer); its figures, or nothing on timeout.
  std::optional<dem_nerf::SolveAnswer> waitForSolve(const std::string& cause, double seconds) {
    std::uint32_t before = 0;  // the latest answer seen before the mark
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (std::size_t i = 0; i < mark_; ++i) before = std::max(before, received_[i].last_solve.sequence);
    }
    dem_nerf::TrainingStatus found;
    const auto answered = [&](const dem_nerf::TrainingStatus& status) {
      return status.last_solve.sequence > before && status.last_solve.cause.find(cause) != std::string::npos;
    };
    if (!waitUntil(answered, seconds, &found)) return std::nullopt;
    return found.last_solve;
  }

  /// Later waits only look at statuses that arrive from now on.
  void mark() {
    ros::spinOnce();
    std::lock_guard<std::mutex> lock(mutex_);
    mark_ = received_.size();
  }

  /// True when any status since the mark is an error whose message holds `text`.
  bool sawError(const std::string& text) {
    ros::spinOnce();
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = mark_; i < received_.size(); ++i) {
      if (received_[i].stage == "error" && received_[i].message.find(text) != std::string::npos) return true;
    }
    return false;
  }

 private:
  void onStatus(const dem_nerf::TrainingStatusConstPtr& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    received_.push_back(*status);
  }
  ros::Subscriber subscriber_;
  std::mutex mutex_;
  std::vector<dem_nerf::TrainingStatus> received_;
  std::size_t mark_ = 0;
};

/// Spins until `done` holds or the time is up; returns done().
inline bool spinUntil(const std::function<bool()>& done, double seconds) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(0.02).sleep();
  }
  return done();
}

/// A 0.1 x 0.02 x 0.02 m bar along +x sampled every `h` (10 mm: 99 particles, small, so that each
/// solve stays short on a loaded 2-core machine); the outer layer carries normals and areas
/// (cuboid_test.yaml clamps its x = 0 end).
inline demnerf::core::ParticleCloud barParticles(double h = 0.01) {
  const int n = static_cast<int>(std::lround(0.1 / h)), m = static_cast<int>(std::lround(0.02 / h));
  demnerf::core::ParticleCloud cloud;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= m; ++j) {
      for (int k = 0; k <= m; ++k) {
        Eigen::Vector3d normal = Eigen::Vector3d::Zero();
        if (i == 0) normal.x() = -1;
        if (i == n) normal.x() = 1;
        if (j == 0) normal.y() = -1;
        if (j == m) normal.y() = 1;
        if (k == 0) normal.z() = -1;
        if (k == m) normal.z() = 1;
        const bool surface = !normal.isZero();
        cloud.positions.emplace_back(i * h, -0.01 + j * h, -0.01 + k * h);
        cloud.volumes.push_back(h * h * h);
        cloud.normals.push_back(surface ? Eigen::Vector3d(normal.normalized()) : normal);
        cloud.areas.push_back(surface ? h * h : 0.0);
        cloud.colors.push_back({200, 200, 200});
      }
    }
  }
  return cloud;
}

/// Publishes the static frame "tool" 0.1 m along x of "world" (the bar's free end), where the
/// checks' wrenches are expressed.
inline void broadcastToolFrame(tf2_ros::StaticTransformBroadcaster& broadcaster) {
  geometry_msgs::TransformStamped tool;
  tool.header.stamp = ros::Time::now();
  tool.header.frame_id = "world";
  tool.child_frame_id = "tool";
  tool.transform.translation.x = 0.1;
  tool.transform.rotation.w = 1.0;
  broadcaster.sendTransform(tool);
}

/// Latches `bar` on /particles in frame "world"; keep the publisher alive while the node needs it.
inline ros::Publisher publishParticles(ros::NodeHandle& node, const demnerf::core::ParticleCloud& bar) {
  ros::Publisher particles = node.advertise<sensor_msgs::PointCloud2>("/particles", 1, true);
  std_msgs::Header header;
  header.frame_id = "world";
  header.stamp = ros::Time::now();
  particles.publish(dem_nerf::toPointCloud2(bar, header));
  return particles;
}

/// The half-space x <= x0 (normal_x = 1) or x >= x0 (normal_x = -1).
inline dem_nerf::Region halfspace(double x0, double normal_x) {
  dem_nerf::Region region;
  region.type = dem_nerf::Region::HALFSPACE;
  region.pose.position.x = x0;
  region.pose.orientation.w = 1.0;
  region.normal.x = normal_x;
  return region;
}

}  // namespace dem_nerf_test
