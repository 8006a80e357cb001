#include "nodes/dem/interactive_push.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "ros_params/parameters.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;
using visualization_msgs::InteractiveMarker;
using visualization_msgs::InteractiveMarkerControl;
using visualization_msgs::InteractiveMarkerFeedback;
using visualization_msgs::Marker;

// A control along one of the marker's axes (rviz reads the axis from the control's orientation:
// identity-like x, then y and z as the usual quarter turns).
InteractiveMarkerControl axisControl(const std::string& name, std::uint8_t mode, char axis) {
  InteractiveMarkerControl control;
  control.name = name;
  control.interaction_mode = mode;
  const double h = std::sqrt(0.5);
  control.orientation.w = h;
  control.orientation.x = axis == 'x' ? h : 0.0;
  control.orientation.y = axis == 'z' ? h : 0.0;  // rviz's convention: (w, 0, 1, 0) moves along z
  control.orientation.z = axis == 'y' ? h : 0.0;
  return control;
}

Marker shape(std::uint8_t type, const Eigen::Vector3d& scale, float r, float g, float b, float a) {
  Marker marker;
  marker.type = type;
  marker.scale.x = scale.x();
  marker.scale.y = scale.y();
  marker.scale.z = scale.z();
  marker.color.r = r;
  marker.color.g = g;
  marker.color.b = b;
  marker.color.a = a;
  marker.pose.orientation.w = 1.0;
  return marker;
}

// The push marker: the patch sphere with an arrow into the body (drag it to move the patch),
// arrows to push and rings to twist.
InteractiveMarker pushMarker(const std::string& frame, const Eigen::Isometry3d& rest, double scale, double radius) {
  InteractiveMarker marker;
  marker.header.frame_id = frame;
  marker.name = "push";
  marker.description = "push: drag arrows/rings; move the sphere to pick the patch";
  marker.pose = tf2::toMsg(rest);
  marker.scale = static_cast<float>(scale);
  InteractiveMarkerControl patch;
  patch.name = "patch";
  patch.interaction_mode = InteractiveMarkerControl::MOVE_3D;
  patch.always_visible = true;
  patch.markers.push_back(shape(Marker::SPHERE, Eigen::Vector3d::Constant(2.0 * radius), 1.0f, 0.5f, 0.1f, 0.6f));
  Marker arrow = shape(Marker::ARROW, Eigen::Vector3d(0.1 * scale, 0.2 * scale, 0.3 * scale), 1.0f, 0.3f, 0.1f, 1.0f);
  geometry_msgs::Point tail, head;  // in the marker's frame: from outside the body to the patch
  tail.x = -scale;
  arrow.points = {tail, head};
  patch.markers.push_back(arrow);
  marker.controls.push_back(patch);
  for (const char axis : {'x', 'y', 'z'}) {
    marker.controls.push_back(axisControl(std::string("push_") + axis, InteractiveMarkerControl::MOVE_AXIS, axis));
    marker.controls.push_back(axisControl(std::string("twist_") + axis, InteractiveMarkerControl::ROTATE_AXIS, axis));
  }
  return marker;
}

// The fixture box: drag the box or its arrows; it stays axis-aligned like a scenario's boxes.
InteractiveMarker fixtureMarker(const std::string& frame, const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  InteractiveMarker marker;
  marker.header.frame_id = frame;
  marker.name = "fixture";
  marker.description = "fixture box: let go to clamp the particles in it";
  marker.pose.position.x = center.x();
  marker.pose.position.y = center.y();
  marker.pose.position.z = center.z();
  marker.pose.orientation.w = 1.0;
  marker.scale = static_cast<float>(1.2 * size.maxCoeff());
  InteractiveMarkerControl box;
  box.name = "box";
  box.interaction_mode = InteractiveMarkerControl::MOVE_3D;
  box.always_visible = true;
  box.markers.push_back(shape(Marker::CUBE, size, 0.2f, 0.4f, 1.0f, 0.4f));
  marker.controls.push_back(box);
  for (const char axis : {'x', 'y', 'z'}) {
    InteractiveMarkerControl move = axisControl(std::string("move_") + axis, InteractiveMarkerControl::MOVE_AXIS, axis);
    move.orientation_mode = InteractiveMarkerControl::FIXED;
    marker.controls.push_back(move);
  }
  return marker;
}

// The feedback's pose; a client's zero or NaN quaternion is refused rather than turned into a torque.
Eigen::Isometry3d poseOf(const InteractiveMarkerFeedback& feedback) {
  const auto& q = feedback.pose.orientation;
  const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  if (!std::isfinite(rotation.norm()) || rotation.norm() < 1e-6)
    throw Error("the marker's orientation is no rotation (a zero or NaN quaternion)");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(feedback.pose.position.x, feedback.pose.position.y, feedback.pose.position.z);
  if (!pose.translation().allFinite()) throw Error("the marker's position holds NaN or Inf");
  return pose;
}

}  // namespace

bool InteractivePush::enabled(const ros::NodeHandle& private_node) {
  bool on = false;
  private_node.param("interactive", on, on);
  return on;
}

PushConfig InteractivePush::readConfig(const ros::NodeHandle& private_node) {
  PushConfig config;
  readNumber(private_node, "push_force_per_metre", config.force_per_metre, 0.0);
  readNumber(private_node, "push_torque_per_radian", config.torque_per_radian, 0.0);
  readNumber(private_node, "push_fixture_size", config.fixture_size, 0.0);
  return config;
}

InteractivePush::InteractivePush(const ros::NodeHandle& private_node, const std::string& frame, double contact_radius,
                                 const PushConfig& config, Hooks hooks)
    : frame_(frame),
      contact_radius_(contact_radius),
      config_(config),
      hooks_(std::move(hooks)),
      server_(private_node.resolveName("push"), "", false) {}

void InteractivePush::setBody(const demnerf::core::ParticleCloud& cloud, const demnerf::core::Scenario& scenario) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool first = !cloud_;
  cloud_ = cloud;
  Eigen::AlignedBox3d box;
  for (const auto& p : cloud.positions) box.extend(p);
  scales_ = pushScales(config_, scenario.material, box.sizes());
  marker_scale_ = std::max(0.2 * box.diagonal().norm(), 4.0 * contact_radius_);
  SurfacePoint point;
  if (first) {
    point = initialPushPoint(cloud, scenario);
    fixture_size_ = fixtureBoxSize(cloud, scenario, config_);
    fixture_center_ = initialFixtureCenter(cloud, scenario, point.position);
  } else {
    point = nearestSurfacePoint(cloud, rest_.translation());
  }
  rest_ = restPose(point);
  const Placement placement = currentPlacement();
  lock.unlock();  // the server calls onPush under its own lock, which takes mutex_: never the other way
  insertMarkers(placement);
}

InteractivePush::Placement InteractivePush::currentPlacement() const {
  return Placement{rest_, fixture_center_, fixture_size_, marker_scale_};
}

void InteractivePush::insertMarkers(const Placement& placement) {
  server_.insert(pushMarker(frame_, placement.rest, placement.scale, contact_radius_),
                 [this](const Feedback& feedback) { onPush(feedback); });
  server_.insert(fixtureMarker(frame_, placement.fixture_center, placement.fixture_size),
                 [this](const Feedback& feedback) { onFixture(feedback); });
  server_.applyChanges();
}

void InteractivePush::onPush(const Feedback& feedback) {
  try {
    const bool update = feedback->event_type == InteractiveMarkerFeedback::POSE_UPDATE;
    const bool release = feedback->event_type == InteractiveMarkerFeedback::MOUSE_UP;
    if (!update && !release) return;
    if (!feedback->header.frame_id.empty() && feedback->header.frame_id != frame_)
      throw Error("feedback in frame '" + feedback->header.frame_id + "', the markers live in '" + frame_ + "'");
    const Eigen::Isometry3d pose = poseOf(*feedback);
    demnerf::core::Load load;
    std::optional<Placement> moved;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!cloud_) throw Error("no particle cloud yet to push");
      if (feedback->control_name == "patch") {
        if (!release) return;  // the patch is chosen where the sphere is let go
        rest_ = restPose(nearestSurfacePoint(*cloud_, pose.translation()));
        moved = currentPlacement();
        load = pushLoad(rest_, rest_, scales_, contact_radius_);  // a new patch starts unloaded
      } else {
        load = pushLoad(rest_, pose, scales_, contact_radius_);
      }
    }
    if (moved) insertMarkers(*moved);  // snapped onto the surface, arrows along the new normal
    hooks_.push(load);
  } catch (const std::exception& error) {
    hooks_.refuse("push", std::string("push marker: ") + error.what());
  }
}

void InteractivePush::onFixture(const Feedback& feedback) {
  try {
    if (feedback->event_type != InteractiveMarkerFeedback::MOUSE_UP) return;  // fixtures move on release
    if (!feedback->header.frame_id.empty() && feedback->header.frame_id != frame_)
      throw Error("feedback in frame '" + feedback->header.frame_id + "', the markers live in '" + frame_ + "'");
    const Eigen::Vector3d center = poseOf(*feedback).translation();
    if (!center.allFinite()) throw Error("the fixture marker's position holds NaN or Inf");
    Eigen::Vector3d size;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fixture_center_ = center;
      size = fixture_size_;
    }
    hooks_.fixture(center, size);
  } catch (const std::exception& error) {
    hooks_.refuse("fixture_box", std::string("fixture box: ") + error.what());
  }
}

}  // namespace dem_nerf
