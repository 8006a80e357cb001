// Space carving in nerf_node against `demnerf extract --solid-cameras DIR`: one capture of a ball
// seen from one side, once read from disk as the CLI reads it and once sent as the messages
// dataset_player sends (Image, CameraInfo, tf) through nerf_node's frame intake into keyframes,
// must carve the same solid: the node's keyframes are the same cameras as the dataset's.

#include <gtest/gtest.h>
#include <tf2_ros/buffer.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/surface_flags.hpp"
#include "conversions/dataset_messages.hpp"
#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/solid_body.hpp"
#include "nodes/nerf/frame_intake.hpp"
#include "nodes/nerf/nerf_node_config.hpp"

namespace {

namespace fs = std::filesystem;
using demnerf::core::Frame;

// A ball of radius 0.3 at the origin in [-0.4, 0.4]^3, density kLevel at its surface.
constexpr double kBall = 0.3, kLevel = 2.5;

demnerf::geometry::DensityGrid ballGrid() {
  const demnerf::geometry::DensityFunction ball = [](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
      sigma[i] = static_cast<float>(kLevel + 1000.0 * (kBall - p.norm()));
    }
  };
  const Eigen::AlignedBox3d box(Eigen::Vector3d::Constant(-0.4), Eigen::Vector3d::Constant(0.4));
  return demnerf::geometry::sampleDensityInBox(ball, box, 48);
}

// A 60-degree camera with a little barrel distortion 2.5 from the origin along `direction`,
// looking at it (REP-103 optical frame), its grey 200 x 200 image holding the whole box.
Frame cameraFrom(const Eigen::Vector3d& direction, int index) {
  Frame frame;
  frame.camera.width = frame.camera.height = 200;
  frame.camera.fx = frame.camera.fy = 100.0 / std::tan(M_PI / 6.0);
  frame.camera.cx = frame.camera.cy = 100.0;
  frame.camera.k1 = -0.05;
  const Eigen::Vector3d z = -direction.normalized();
  const Eigen::Vector3d helper = std::abs(z.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x = helper.cross(z).normalized();
  frame.world_from_camera.linear() << x, z.cross(x), z;
  frame.world_from_camera.translation() = 2.5 * direction.normalized();
  frame.rgba = cv::Mat(200, 200, CV_32FC4, cv::Scalar(0.5, 0.5, 0.5, 1.0));
  frame.file_path = "images/camera_" + std::to_string(index) + ".png";
  return frame;
}

// The capture written as a NeRF-synthetic dataset: one camera in front (+x), four 50 degrees off.
std::string writeCapture() {
  const fs::path root = fs::path(::testing::TempDir()) / ("carving_" + std::to_string(::getpid()));
  fs::create_directories(root / "images");
  std::vector<Frame> frames{cameraFrom(Eigen::Vector3d::UnitX(), 0)};
  const double c = std::cos(50.0 * M_PI / 180.0), s = std::sin(50.0 * M_PI / 180.0);
  const Eigen::Vector3d sides[] = {Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
                                   -Eigen::Vector3d::UnitZ()};
  for (const Eigen::Vector3d& side : sides)
    frames.push_back(cameraFrom(c * Eigen::Vector3d::UnitX() + s * side, static_cast<int>(frames.size())));
  for (const Frame& frame : frames) demnerf::core::writeImagePng((root / frame.file_path).string(), frame.rgba);
  demnerf::core::writeTransforms((root / "transforms_train.json").string(), frames,
                                 Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-0.4), Eigen::Vector3d::Constant(0.4)));
  return root.string();
}

// What nerf_node's keyframes hold after dataset_player has played the capture to it.
std::vector<Frame> keyframesFromMessages(const std::string& capture, const dem_nerf::NerfNodeConfig& config) {
  tf2_ros::Buffer tf;
  tf.setUsingDedicatedThread(true);  // as nerf_node's TransformListener sets it; the intake polls with no wait
  dem_nerf::FrameIntake intake(config.intake(), tf);
  const demnerf::core::Dataset dataset = demnerf::core::loadDataset(capture);
  dem_nerf::FrameNaming naming;
  naming.world_frame = config.world_frame;
  for (std::size_t i = 0; i < dataset.train.size(); ++i) {
    const dem_nerf::FrameMessages messages = dem_nerf::toMessages(dataset.train[i], i, ros::Time(10.0 + i), naming);
    tf.setTransform(messages.pose, "dataset_player", true);
    intake.add(messages.image, messages.camera_info);
  }
  std::vector<std::string> dropped;
  std::vector<Frame> keyframes = intake.poll(&dropped);
  EXPECT_TRUE(dropped.empty()) << dropped.front();
  return keyframes;
}

TEST(NerfNodeCarving, KeyframesCarveAsTheCommandLinesDatasetDoes) {
  ros::Time::init();
  const std::string capture = writeCapture();
  XmlRpc::XmlRpcValue extraction;
  extraction["solid_radius"] = 0.05;
  extraction["solid_views"] = 2;
  const dem_nerf::NerfNodeConfig node = dem_nerf::NerfNodeConfig::fromParameters(dem_nerf::ParameterMap{{"extraction", extraction}});
  const std::vector<Frame> keyframes = keyframesFromMessages(capture, node);
  ASSERT_EQ(keyframes.size(), 5u);
  const dem_nerf::SurfaceConfig from_node = dem_nerf::withTrainingCameras(node.extraction, keyframes, "the keyframes");
  const dem_nerf::SurfaceConfig from_cli = demnerf::cli::surfaceFlags(demnerf::cli::Arguments(
      {"--solid-radius", "0.05", "--solid-cameras", capture, "--solid-views", "2"}, {}));
  ASSERT_EQ(from_node.mesh.solid.cameras.size(), 5u);
  ASSERT_EQ(from_cli.mesh.solid.cameras.size(), 5u);
  EXPECT_EQ(from_node.mesh.solid.min_views, 2);
  EXPECT_EQ(from_cli.mesh.solid.min_views, 2);

  const demnerf::geometry::DensityGrid grid = ballGrid();
  demnerf::geometry::SolidReport node_report, cli_report;
  const auto node_solid = demnerf::geometry::solidifyField(grid, kLevel, from_node.mesh.solid, &node_report);
  const auto cli_solid = demnerf::geometry::solidifyField(grid, kLevel, from_cli.mesh.solid, &cli_report);
  EXPECT_GT(cli_report.hidden_nodes, 500u);  // the ball's shadow is filled: carving ran
  EXPECT_EQ(node_report.hidden_nodes, cli_report.hidden_nodes);
  EXPECT_EQ(node_report.unseen_nodes, cli_report.unseen_nodes);
  // Node for node (measured: dropping the CameraInfo's k1 changes 4 nodes, fx 1 % off 64).
  ASSERT_EQ(node_solid.values.size(), cli_solid.values.size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < cli_solid.values.size(); ++i) differing += node_solid.values[i] != cli_solid.values[i];
  EXPECT_EQ(differing, 0u);
  // Straight behind the ball (-x) is filled; beside it (+y), where the tilted cameras look, is not.
  const Eigen::Vector3i& n = grid.dims;
  EXPECT_GT(node_solid.at(2, n.y() / 2, n.z() / 2), kLevel);
  EXPECT_LT(node_solid.at(n.x() / 2, n.y() - 3, n.z() / 2), kLevel);
  fs::remove_all(capture);
}

TEST(NerfNodeCarving, TooFewOrNoCamerasAreRefusedWithTheWayOut) {
  dem_nerf::SurfaceConfig config;
  config.mesh.solid.radius = 0.05;
  config.solid_views = 3;
  const auto refusal = [&](const std::vector<Frame>& frames) -> std::string {
    try {
      dem_nerf::withTrainingCameras(config, frames, "nerf_node's keyframes");
    } catch (const demnerf::core::Error& error) {
      return error.what();
    }
    return "";
  };
  EXPECT_NE(refusal({}).find("there are none in nerf_node's keyframes"), std::string::npos);
  const std::vector<Frame> two{cameraFrom(Eigen::Vector3d::UnitX(), 0), cameraFrom(Eigen::Vector3d::UnitY(), 1)};
  EXPECT_NE(refusal(two).find("only 2 in nerf_node's keyframes: give at most 2"), std::string::npos);
  config.solid_views = 2;
  EXPECT_EQ(refusal(two), "");
  config.solid_views = 0;  // no carving: no cameras needed, none attached
  EXPECT_TRUE(dem_nerf::withTrainingCameras(config, {}, "nerf_node's keyframes").mesh.solid.cameras.empty());
}

}  // namespace
