// rostest node: nerf_node trains the cuboid; a corrupt or truncated model file given to ~load is
// refused (the node keeps answering and loads the real one); dem_node renders its deformed
// particles through the NeRF on ~rendered, only while someone subscribes, saying on ~status
// when the render camera has no tf; a downward tip load visibly lowers the free end.

#include <dem_nerf/ExtractParticles.h>
#include <dem_nerf/LoadModel.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/RenderView.h>
#include <dem_nerf/Solve.h>
#include <gtest/gtest.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <optional>

#include "check_helpers.hpp"

namespace {

using dem_nerf_test::StatusRecorder;
using dem_nerf_test::spinUntil;

constexpr int kWidth = 96, kHeight = 64;

sensor_msgs::CameraInfo renderCameraInfo() {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "render_camera";
  info.width = kWidth;
  info.height = kHeight;
  const double f = 0.5 * kWidth / std::tan(30.0 * M_PI / 180.0);  // 60 degrees across
  info.K = {f, 0, 0.5 * kWidth, 0, f, 0.5 * kHeight, 0, 0, 1};
  return info;
}

// The camera 0.3 m in front of the cuboid (x in [0, 0.125] m), looking along +y with world z up,
// so image columns run along +x (clamp left, free end right) and image rows down world -z.
Eigen::Isometry3d renderPose() {
  Eigen::Matrix3d rotation;
  rotation.col(0) = Eigen::Vector3d::UnitX();   // optical x: right
  rotation.col(1) = -Eigen::Vector3d::UnitZ();  // optical y: down
  rotation.col(2) = Eigen::Vector3d::UnitY();   // optical z: forward
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = Eigen::Vector3d(0.0625, -0.3, 0.0);
  return pose;
}

geometry_msgs::Pose toPose(const Eigen::Isometry3d& pose) {
  geometry_msgs::Pose message;
  const Eigen::Quaterniond q(pose.linear());
  message.position.x = pose.translation().x();
  message.position.y = pose.translation().y();
  message.position.z = pose.translation().z();
  message.orientation.x = q.x();
  message.orientation.y = q.y();
  message.orientation.z = q.z();
  message.orientation.w = q.w();
  return message;
}

using dem_nerf_test::halfspace;

// Clamp x <= 0.015 m, pull the surface at x >= 0.105 m down with `force_z` N.
dem_nerf::LoadCase cantilever(double force_z) {
  dem_nerf::LoadCase load_case;
  load_case.header.frame_id = "world";
  dem_nerf::Fixture clamp;
  clamp.name = "clamp";
  clamp.region = halfspace(0.015, 1.0);
  load_case.fixtures.push_back(clamp);
  dem_nerf::Load load;
  load.name = "tip";
  load.region = halfspace(0.105, -1.0);
  load.wrench.force.z = force_z;
  load_case.loads.push_back(load);
  return load_case;
}

std::size_t opaquePixels(const sensor_msgs::Image& image) {
  std::size_t count = 0;
  for (std::size_t i = 3; i < image.data.size(); i += 4) count += image.data[i] > 128 ? 1 : 0;
  return count;
}

/// Mean row of the opaque pixels in columns [c0, c1).
double meanRow(const sensor_msgs::Image& image, int c0, int c1) {
  double sum = 0.0;
  int count = 0;
  for (int v = 0; v < static_cast<int>(image.height); ++v) {
    for (int c = std::max(c0, 0); c < std::min<int>(c1, image.width); ++c) {
      if (image.data[v * image.step + 4 * c + 3] > 128) {
        sum += v;
        ++count;
      }
    }
  }
  return count > 0 ? sum / count : -1.0;
}

bool solve(double force_z, std::string* message = nullptr) {
  dem_nerf::Solve solve;
  solve.request.load_case = cantilever(force_z);
  const bool ok = ros::service::call("/dem_node/solve", solve) && solve.response.ok;
  if (message != nullptr) *message = solve.response.message;
  return ok;
}

// Waits for nerf_node's trained model and particles; the model's path, empty when none came.
std::string waitForTrainedModel(ros::NodeHandle& node) {
  std::mutex mutex;
  std::optional<dem_nerf::ModelInfo> model;
  bool particles_published = false;
  auto model_subscriber = node.subscribe<dem_nerf::ModelInfo>("/nerf_node/model", 1, [&](const dem_nerf::ModelInfoConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    model = *m;
  });
  auto particles_subscriber = node.subscribe<sensor_msgs::PointCloud2>(
      "/nerf_node/particles", 1, [&](const sensor_msgs::PointCloud2ConstPtr&) {
        std::lock_guard<std::mutex> lock(mutex);
        particles_published = true;
      });
  const bool ready = spinUntil(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return model && particles_published;
      },
      100);
  std::lock_guard<std::mutex> lock(mutex);
  return ready ? model->model_path : std::string();
}

// nerf_node ~load: garbage, then a truncated copy of the real file, both refused by name.
void expectCorruptModelsRefused(ros::NodeHandle& node, const std::string& model_path) {
  StatusRecorder nerf_status(node, "/nerf_node/status");
  const std::string garbage = "/tmp/dem_node_render_garbage.nerf", truncated = "/tmp/dem_node_render_truncated.nerf";
  {
    std::ofstream file(garbage, std::ios::binary | std::ios::trunc);
    for (int i = 0; i < 1000; ++i) file << static_cast<char>((i * 7919) % 251);
  }
  {
    std::ifstream in(model_path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 1000u);
    std::ofstream out(truncated, std::ios::binary | std::ios::trunc);
    out << bytes.substr(0, bytes.size() / 2);
  }
  for (const std::string& bad : {garbage, truncated}) {
    nerf_status.mark();
    dem_nerf::LoadModel load;
    load.request.path = bad;
    ASSERT_TRUE(ros::service::call("/nerf_node/load", load)) << "nerf_node did not answer ~load of " << bad;
    EXPECT_FALSE(load.response.ok) << bad;
    EXPECT_NE(load.response.message.find(bad), std::string::npos) << "the reply should name the file: "
                                                                  << load.response.message;
    EXPECT_NE(nerf_status.waitForError(bad, 10), "") << "no error on /nerf_node/status for " << bad;
  }
  std::remove(garbage.c_str());
  std::remove(truncated.c_str());
}

// The tf from world to the render camera, at renderPose().
void broadcastRenderCamera(tf2_ros::StaticTransformBroadcaster& broadcaster) {
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time::now();
  transform.header.frame_id = "world";
  transform.child_frame_id = "render_camera";
  const geometry_msgs::Pose pose = toPose(renderPose());
  transform.transform.translation.x = pose.position.x;
  transform.transform.translation.y = pose.position.y;
  transform.transform.translation.z = pose.position.z;
  transform.transform.rotation = pose.orientation;
  broadcaster.sendTransform(transform);
}

// The deformed renders under a small and a large downward load on the free end: the same object
// as nerf_node's render at rest (`rest_pixels` opaque), its free end lower, its clamped end not.
void expectTheFreeEndMovesDown(const sensor_msgs::Image& small, const sensor_msgs::Image& large, std::size_t rest_pixels) {
  EXPECT_EQ(small.encoding, "rgba8");
  EXPECT_EQ(small.width, static_cast<unsigned>(kWidth));
  EXPECT_EQ(small.height, static_cast<unsigned>(kHeight));
  EXPECT_EQ(small.header.frame_id, "render_camera");
  const std::size_t small_pixels = opaquePixels(small);
  EXPECT_GT(small_pixels, 0.7 * rest_pixels);
  EXPECT_LT(small_pixels, 1.3 * rest_pixels);
  // Columns of the object; its free end (right) must move down, its clamped end (left) not.
  int c0 = kWidth, c1 = -1;
  for (int v = 0; v < kHeight; ++v) {
    for (int c = 0; c < kWidth; ++c) {
      if (small.data[v * small.step + 4 * c + 3] > 128) {
        c0 = std::min(c0, c);
        c1 = std::max(c1, c);
      }
    }
  }
  ASSERT_LT(c0, c1);
  const int span = c1 - c0 + 1;
  const double tip_small = meanRow(small, c0 + 3 * span / 4, c1 + 1), tip_large = meanRow(large, c0 + 3 * span / 4, c1 + 1);
  const double root_small = meanRow(small, c0, c0 + span / 8), root_large = meanRow(large, c0, c0 + span / 8);
  std::printf("object columns %d..%d; free end mean row %.2f -> %.2f px, clamped end %.2f -> %.2f px\n", c0, c1,
              tip_small, tip_large, root_small, root_large);
  EXPECT_GT(tip_large - tip_small, 1.5) << "the loaded end should move down in the image";
  // The clamp holds x <= 0.015 m, but how far the columns next to it move with the bent beam
  // depends on the NeRF's extracted body (measured 0.2-3.9 px for free-end moves of 3.7-11.7 px).
  EXPECT_LT(std::abs(root_large - root_small), 0.5 * (tip_large - tip_small))
      << "the clamped end should move much less than the loaded one";
}

TEST(DemNodeRender, CorruptModelsAreRefusedAndTheDeformedObjectIsRendered) {
  ros::NodeHandle node;
  const std::string model_path = waitForTrainedModel(node);
  ASSERT_FALSE(model_path.empty()) << "nerf_node published no trained model and particles";
  expectCorruptModelsRefused(node, model_path);
  // The good file loads (training may still be winding down for a moment), and renders.
  dem_nerf::LoadModel good;
  good.request.path = model_path;
  EXPECT_TRUE(spinUntil([&] { return ros::service::call("/nerf_node/load", good) && good.response.ok; }, 20))
      << good.response.message;
  dem_nerf::RenderView view;
  view.request.camera_info = renderCameraInfo();
  view.request.pose = toPose(renderPose());
  ASSERT_TRUE(ros::service::call("/nerf_node/render", view));
  ASSERT_TRUE(view.response.ok) << view.response.message;
  const std::size_t rest_pixels = opaquePixels(view.response.image);
  EXPECT_GT(rest_pixels, 0.05 * kWidth * kHeight) << "the cuboid should fill part of the view";

  // --- dem_node: particles from the NeRF, a render camera without tf, nobody subscribed.
  dem_nerf::ExtractParticles extract;
  extract.request.spacing = 0.02;  // coarse: a few hundred particles keep the FEM solves short
  ASSERT_TRUE(ros::service::call("/nerf_node/extract", extract));
  ASSERT_TRUE(extract.response.ok) << extract.response.message;
  ros::Publisher particles = node.advertise<sensor_msgs::PointCloud2>("/particles", 1, true);
  particles.publish(extract.response.cloud);
  ros::Publisher camera_info = node.advertise<sensor_msgs::CameraInfo>("/dem_node/render_camera_info", 1, true);
  camera_info.publish(renderCameraInfo());
  StatusRecorder dem_status(node, "/dem_node/status");
  dem_status.mark();
  std::string message;
  EXPECT_TRUE(spinUntil([&] { return solve(-0.01, &message); }, 30)) << message;
  // Lazy: nobody listens to ~rendered, so nothing was rendered (without tf it would have failed).
  EXPECT_TRUE(dem_status.waitUntil(
      [](const dem_nerf::TrainingStatus& s) { return s.last_solve.sequence > 0 && s.renders == 0; }, 5));
  EXPECT_FALSE(dem_status.sawError("~rendered"));

  // A subscriber arrives: the latest result is rendered at once, and the missing tf is reported.
  std::mutex mutex;
  std::vector<sensor_msgs::Image> images;
  auto rendered = node.subscribe<sensor_msgs::Image>("/dem_node/rendered", 5, [&](const sensor_msgs::ImageConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    images.push_back(*m);
  });
  EXPECT_NE(dem_status.waitForError("no tf from 'world' to ~render_frame 'render_camera'", 15), "");

  // With the tf: a small load, then a large downward one on the free end.
  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcastRenderCamera(broadcaster);
  ros::WallDuration(0.5).sleep();
  auto imageCount = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return images.size();
  };
  auto latestImage = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return images.back();
  };
  const std::size_t before = imageCount();
  ASSERT_TRUE(solve(-0.01, &message)) << message;
  ASSERT_TRUE(spinUntil([&] { return imageCount() > before; }, 30)) << "no image on /dem_node/rendered";
  const sensor_msgs::Image small = latestImage();
  ASSERT_TRUE(solve(-20.0, &message)) << message;
  std::printf("large load: %s\n", message.c_str());
  ASSERT_TRUE(spinUntil([&] { return imageCount() > before + 1; }, 30)) << "no second image";
  const sensor_msgs::Image large = latestImage();
  expectTheFreeEndMovesDown(small, large, rest_pixels);
  // ~status counts the renders it published (each one an image here).
  const std::size_t received = imageCount();
  EXPECT_TRUE(dem_status.waitUntil([&](const dem_nerf::TrainingStatus& s) { return s.renders >= received; }, 5));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dem_node_render_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
