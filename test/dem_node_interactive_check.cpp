// rostest node: dem_node's interactive push and live settings through a real master. The check
// does what rviz does with the markers (feedback on /dem_node/push/feedback) and what rqt does
// with the settings (dynamic_reconfigure's ~set_parameters), and reads the displaced cloud.

#include <dem_nerf/TrainingStatus.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/InteractiveMarkerFeedback.h>
#include <visualization_msgs/InteractiveMarkerInit.h>

#include <cstdio>
#include <mutex>
#include <optional>
#include <string>

#include "check_helpers.hpp"
#include "conversions/cloud_conversions.hpp"

namespace {

using visualization_msgs::InteractiveMarkerFeedback;

struct Deflection {
  double tip_uz = 0.0;      // mean z displacement of the free end (x = 0.1)
  double tip_lateral = 0.0;  // mean |ux| + |uy| there
  double root_max = 0.0;    // largest |u| at x = 0 (the scenario's clamp)
  double layer_max = 0.0;   // largest |u| at x = 0.015
};

class InteractiveCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    displaced_sub_ = node_.subscribe<sensor_msgs::PointCloud2>(
        "/dem_node/displaced", 1, [this](const sensor_msgs::PointCloud2ConstPtr& message) {
          std::lock_guard<std::mutex> lock(mutex_);
          displaced_ = *message;
        });
    init_sub_ = node_.subscribe<visualization_msgs::InteractiveMarkerInit>(
        "/dem_node/push/update_full", 1, [this](const visualization_msgs::InteractiveMarkerInitConstPtr& message) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const auto& marker : message->markers)
            if (marker.name == "push") push_rest_ = marker.pose;
        });
    feedback_ = node_.advertise<InteractiveMarkerFeedback>("/dem_node/push/feedback", 10);
  }

  // Feedback as rviz sends it while a control is dragged and when it is let go.
  void drag(const std::string& marker, const std::string& control, const geometry_msgs::Pose& pose) {
    InteractiveMarkerFeedback feedback;
    feedback.header.frame_id = "world";
    feedback.client_id = "/rviz/InteractiveMarkers";
    feedback.marker_name = marker;
    feedback.control_name = control;
    feedback.pose = pose;
    for (const auto event : {InteractiveMarkerFeedback::MOUSE_DOWN, InteractiveMarkerFeedback::POSE_UPDATE,
                             InteractiveMarkerFeedback::MOUSE_UP}) {
      feedback.header.stamp = ros::Time::now();
      feedback.event_type = event;
      feedback_.publish(feedback);
      ros::WallDuration(0.05).sleep();
    }
  }

  // The displaced cloud of the next solve whose cause (~status's last_solve) holds `cause`.
  std::optional<Deflection> answer(dem_nerf_test::StatusRecorder& status, const std::string& cause) {
    if (!status.waitForSolve(cause, 60)) return std::nullopt;
    ros::WallDuration(0.2).sleep();  // the cloud goes out before the status
    ros::spinOnce();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!displaced_) return std::nullopt;
    const auto field = dem_nerf::resultFromPointCloud2(*displaced_, /*displaced_positions=*/true);
    Deflection d;
    int tip = 0;
    for (std::size_t i = 0; i < field.size(); ++i) {
      const Eigen::Vector3d& x = field.positions[i];
      const Eigen::Vector3d& u = field.displacements[i];
      if (x.x() > 0.1 - 1e-4) {
        d.tip_uz += u.z();
        d.tip_lateral += std::abs(u.x()) + std::abs(u.y());
        ++tip;
      }
      if (x.x() < 1e-4) d.root_max = std::max(d.root_max, u.norm());
      if (std::abs(x.x() - 0.015) < 1e-4) d.layer_max = std::max(d.layer_max, u.norm());
    }
    d.tip_uz /= std::max(tip, 1);
    d.tip_lateral /= std::max(tip, 1);
    return d;
  }

  static dynamic_reconfigure::Reconfigure reconfigure(const std::string& name, double value) {
    dynamic_reconfigure::Reconfigure call;
    dynamic_reconfigure::DoubleParameter parameter;
    parameter.name = name;
    parameter.value = value;
    call.request.config.doubles.push_back(parameter);
    return call;
  }

  static double valueOf(const dynamic_reconfigure::Config& config, const std::string& name) {
    for (const auto& parameter : config.doubles)
      if (parameter.name == name) return parameter.value;
    return std::nan("");
  }

  ros::NodeHandle node_;
  ros::Subscriber displaced_sub_, init_sub_;
  ros::Publisher feedback_;
  std::mutex mutex_;
  std::optional<sensor_msgs::PointCloud2> displaced_;
  std::optional<geometry_msgs::Pose> push_rest_;
};

TEST_F(InteractiveCheck, DraggingTheMarkersAndChangingTheSettingsMoveTheDisplacedCloud) {
  dem_nerf_test::StatusRecorder status(node_, "/dem_node/status");
  const demnerf::core::ParticleCloud bar = dem_nerf_test::barParticles(0.005);
  ros::Publisher particles = dem_nerf_test::publishParticles(node_, bar);
  // The push marker appears on the bar once dem_node has the particles.
  ASSERT_TRUE(dem_nerf_test::spinUntil(
      [&] {
        std::lock_guard<std::mutex> lock(mutex_);
        return push_rest_.has_value() && feedback_.getNumSubscribers() > 0;
      },
      30))
      << "no push marker on /dem_node/push/update_full (or nobody takes feedback)";
  geometry_msgs::Pose rest;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rest = *push_rest_;
  }
  EXPECT_NEAR(rest.position.x, 0.1, 1e-6) << "the marker starts on the free end, away from the clamp";

  // Drag the push arrow 2 mm down and let go: the free end goes down with it.
  status.mark();
  geometry_msgs::Pose pushed = rest;
  pushed.position.z -= 0.002;
  drag("push", "push_z", pushed);
  const auto first = answer(status, "push");
  ASSERT_TRUE(first.has_value()) << "no solve answered the push";
  std::printf("push 2 mm down: tip uz %.3g m, lateral %.3g m\n", first->tip_uz, first->tip_lateral);
  EXPECT_LT(first->tip_uz, -2e-4) << "the free end should follow the push down";
  EXPECT_LT(first->root_max, 1e-9) << "the clamp moved";
  EXPECT_GT(first->layer_max, 1e-7) << "x = 0.015 lies outside the clamp and bends";

  // Live settings: half the Young's modulus doubles the deflection of the same push.
  ASSERT_TRUE(ros::service::waitForService("/dem_node/set_parameters", ros::Duration(10)));
  status.mark();
  auto softer = reconfigure("youngs_modulus", 0.5e5);
  ASSERT_TRUE(ros::service::call("/dem_node/set_parameters", softer));
  const auto second = answer(status, "live settings");
  ASSERT_TRUE(second.has_value()) << "no re-solve after the Young's modulus changed";
  std::printf("E halved: tip uz %.3g m (ratio %.3f)\n", second->tip_uz, second->tip_uz / first->tip_uz);
  EXPECT_NEAR(second->tip_uz / first->tip_uz, 2.0, 0.3);

  // An invalid value is refused by name and the values in force stay.
  status.mark();
  auto incompressible = reconfigure("poisson_ratio", 0.5);
  ASSERT_TRUE(ros::service::call("/dem_node/set_parameters", incompressible));
  EXPECT_NEAR(valueOf(incompressible.response.config, "poisson_ratio"), 0.3, 1e-12);
  EXPECT_FALSE(status.waitForError("poisson_ratio", 10).empty()) << "the refusal should be on ~status";

  // A load scale of -1 pulls instead of pushing.
  status.mark();
  auto pull = reconfigure("load_scale", -1.0);
  ASSERT_TRUE(ros::service::call("/dem_node/set_parameters", pull));
  const auto third = answer(status, "load_scale");
  ASSERT_TRUE(third.has_value());
  EXPECT_NEAR(third->tip_uz / second->tip_uz, -1.0, 0.2);

  // The fixture box moved off the body is refused; moved to x in [0.0075, 0.0175] it clamps there.
  status.mark();
  geometry_msgs::Pose away;
  away.position.x = 1.0;
  away.orientation.w = 1.0;
  drag("fixture", "box", away);
  EXPECT_FALSE(status.waitForError("fixture box", 10).empty()) << "a box that holds no particle should be refused";
  status.mark();
  geometry_msgs::Pose clamp = away;
  clamp.position.x = 0.0125;
  drag("fixture", "move_x", clamp);
  const auto fourth = answer(status, "fixture box");
  ASSERT_TRUE(fourth.has_value()) << "no solve after the fixture box moved";
  EXPECT_LT(fourth->layer_max, 1e-9) << "x = 0.015 lies in the moved fixture box";
  EXPECT_GT(fourth->tip_uz, 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dem_node_interactive_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
