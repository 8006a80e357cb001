#pragma once
// dem_node's interactive push (~interactive true): an interactive marker server on ~push with two
// markers in ~particles_frame, for rviz's InteractiveMarkers display.
//  - "push" rests on a surface particle, its x axis into the body. Its sphere ("patch" control)
//    moves it: where it is let go, it snaps to the nearest surface particle, which becomes the
//    centre of the contact patch (the particles within ~contact_radius) with no load yet. Its
//    arrows and rings push and twist: the displacement from the rest pose times
//    ~push_force_per_metre is the force, the rotation vector times ~push_torque_per_radian the
//    torque (push_gesture.hpp). Every drag update asks for a solve; the node's solve worker
//    coalesces them (~max_solve_rate), and letting go asks once more, so the last pose is solved.
//  - "fixture" is a box whose region, when it is let go, clamps the particles in it: it replaces
//    the scenario's first fixture (or is the only one).
// What the markers set goes to the node through the hooks; the node solves and publishes.

#include <interactive_markers/interactive_marker_server.h>
#include <ros/ros.h>

#include <functional>
#include <mutex>
#include <optional>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "nodes/dem/push_gesture.hpp"

namespace dem_nerf {

class InteractivePush {
 public:
  struct Hooks {
    /// The push load changed: the node makes it its only load and solves.
    std::function<void(const demnerf::core::Load&)> push;
    /// The fixture box was let go at `center`: the node places it (placeFixtureBox) and solves.
    std::function<void(const Eigen::Vector3d& center, const Eigen::Vector3d& size)> fixture;
    /// Something was refused (cause, message): the node reports it on ~status.
    std::function<void(const std::string&, const std::string&)> refuse;
  };

  /// Whether ~interactive is set, and the ~push_* parameters (core::Error names a bad one).
  static bool enabled(const ros::NodeHandle& private_node);
  static PushConfig readConfig(const ros::NodeHandle& private_node);

  InteractivePush(const ros::NodeHandle& private_node, const std::string& frame, double contact_radius,
                  const PushConfig& config, Hooks hooks);

  /// A new particle cloud: the markers are placed on it (the first time from the scenario, later
  /// snapped to the nearest surface particle of where they were). `material` sets the automatic
  /// stiffnesses.
  void setBody(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario);

 private:
  using Feedback = visualization_msgs::InteractiveMarkerFeedbackConstPtr;
  void onPush(const Feedback& feedback);
  void onFixture(const Feedback& feedback);
  /// Where the markers rest.
  struct Placement {
    Eigen::Isometry3d rest;
    Eigen::Vector3d fixture_center, fixture_size;
    double scale;
  };
  Placement currentPlacement() const;  ///< mutex_ held
  /// Puts both markers in the server at their rest poses; never with mutex_ held (lock order:
  /// the server's lock, then mutex_, as in its feedback callbacks).
  void insertMarkers(const Placement& placement);

  std::string frame_;
  double contact_radius_;
  PushConfig config_;
  Hooks hooks_;
  interactive_markers::InteractiveMarkerServer server_;

  std::mutex mutex_;  // guards everything below
  std::optional<demnerf::core::ParticleCloud> cloud_;
  PushScales scales_;
  Eigen::Isometry3d rest_ = Eigen::Isometry3d::Identity();  ///< the push marker at rest
  Eigen::Vector3d fixture_center_ = Eigen::Vector3d::Zero(), fixture_size_ = Eigen::Vector3d::Zero();
  double marker_scale_ = 0.1;  ///< m: the markers' size, from the body's size
};

}  // namespace dem_nerf
