// nerfstudio's transforms.json (per-frame intrinsics, camera_model, applied_transform) and the
// messages for folders in layouts the loader does not read.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/pose.hpp"

using namespace demnerf::core;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

fs::path freshFolder(const std::string& name) {
  const fs::path folder = fs::temp_directory_path() / ("demnerf_test_layout_" + name);
  fs::remove_all(folder);
  fs::create_directories(folder);
  return folder;
}

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

Json rows(const Eigen::Matrix4d& m, int count) {
  Json out = Json::array();
  for (int r = 0; r < count; ++r) out.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return out;
}

// nerfstudio's COLMAP import: swap x and y, negate z (a proper rotation).
Eigen::Matrix4d colmapAppliedTransform() {
  Eigen::Matrix4d a = Eigen::Matrix4d::Identity();
  a.topLeftCorner<3, 3>() << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  a.topRightCorner<3, 1>() << 0.5, -0.25, 1.0;
  return a;
}

// Camera i in the original capture's world (OpenGL convention, as nerfstudio writes it).
Eigen::Matrix4d originalPose(int i) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.4 * i + 0.1, Eigen::Vector3d(0.2, 1.0, 0.3).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(1.0 + i, -0.5 * i, 2.0);
  return pose.matrix();
}

// Three frames as ns-process-data writes them: poses already moved by applied_transform,
// global OPENCV intrinsics, frame 2 with its own size, focal length and distortion.
Json writeNerfstudioScene(const fs::path& folder) {
  fs::create_directories(folder / "images");
  Json top = {{"camera_model", "OPENCV"}, {"fl_x", 10.0}, {"fl_y", 11.0}, {"cx", 4.0}, {"cy", 3.0},
              {"w", 8},  {"h", 6},      {"k1", 0.01},   {"k2", 0.0},    {"p1", 0.0},  {"p2", 0.0}};
  top["applied_transform"] = rows(colmapAppliedTransform(), 3);
  for (int i = 0; i < 3; ++i) {
    const std::string name = "images/frame_0000" + std::to_string(i + 1) + ".png";
    Json frame = {{"file_path", name}};
    frame["transform_matrix"] = rows(colmapAppliedTransform() * originalPose(i), 4);
    const int width = i == 2 ? 10 : 8;
    if (i == 2) {
      frame.update({{"fl_x", 20.0}, {"cx", 5.0}, {"w", 10}, {"h", 6}, {"k1", 0.02}, {"p1", 0.001}});
    }
    writeImagePng((folder / name).string(), cv::Mat(6, width, CV_32FC3, cv::Scalar(0.2, 0.4, 0.6)));
    top["frames"].push_back(frame);
  }
  std::ofstream(folder / "transforms.json") << top.dump(2);
  return top;
}

}  // namespace

TEST(DatasetLayouts, NerfstudioPerFrameIntrinsicsOverrideTheGlobalOnes) {
  const fs::path folder = freshFolder("nerfstudio");
  writeNerfstudioScene(folder);
  DatasetOptions options;
  options.holdout_every = 0;
  const Dataset dataset = loadDataset(folder.string(), options);
  EXPECT_EQ(dataset.layout, "nerfstudio");
  ASSERT_EQ(dataset.train.size(), 3u);
  const PinholeCamera& global = dataset.train[0].camera;
  EXPECT_EQ(global.width, 8);
  EXPECT_DOUBLE_EQ(global.fx, 10.0);
  EXPECT_DOUBLE_EQ(global.fy, 11.0);
  EXPECT_DOUBLE_EQ(global.k1, 0.01);
  const PinholeCamera& own = dataset.train[2].camera;
  EXPECT_EQ(own.width, 10);
  EXPECT_EQ(dataset.train[2].rgba.cols, 10);
  EXPECT_DOUBLE_EQ(own.fx, 20.0);
  EXPECT_DOUBLE_EQ(own.fy, 11.0);  // not in the frame: the global value
  EXPECT_DOUBLE_EQ(own.cx, 5.0);
  EXPECT_DOUBLE_EQ(own.cy, 3.0);
  EXPECT_DOUBLE_EQ(own.k1, 0.02);
  EXPECT_DOUBLE_EQ(own.p1, 0.001);
  EXPECT_EQ(dataset.train[2].file_path, "images/frame_00003.png");  // relative to the json
}

TEST(DatasetLayouts, NerfstudioPosesAreUsedAsWrittenAndAppliedTransformMapsTheOriginalWorld) {
  const fs::path folder = freshFolder("applied");
  writeNerfstudioScene(folder);
  DatasetOptions options;
  options.holdout_every = 0;
  options.load_images = false;
  const Dataset dataset = loadDataset(folder.string(), options);
  EXPECT_TRUE(dataset.applied_transform.matrix().isApprox(colmapAppliedTransform(), 1e-12));
  for (int i = 0; i < 3; ++i) {
    const Eigen::Isometry3d written(colmapAppliedTransform() * originalPose(i));
    // The file's poses already hold applied_transform (nerfstudio's meaning): not applied twice.
    EXPECT_TRUE(dataset.train[i].world_from_camera.isApprox(openGlToOptical(written), 1e-9)) << i;
    // A point of the original world (the camera centre) lands where the loaded camera is.
    const Eigen::Vector3d centre = originalPose(i).topRightCorner<3, 1>();
    EXPECT_TRUE((dataset.applied_transform * centre).isApprox(dataset.train[i].world_from_camera.translation(), 1e-9));
    // The optical axis (OpenGL -z) keeps its direction through the rotation part.
    const Eigen::Vector3d axis = -originalPose(i).block<3, 1>(0, 2);
    EXPECT_TRUE((dataset.applied_transform.linear() * axis).isApprox(dataset.train[i].world_from_camera.linear().col(2), 1e-9));
  }
}

TEST(DatasetLayouts, CamerasOutsideThePinholeModelAreRejectedWithTheFix) {
  const fs::path folder = freshFolder("fisheye");
  Json top = writeNerfstudioScene(folder);
  DatasetOptions options;
  options.load_images = false;
  auto rewrite = [&](const Json& json) { std::ofstream(folder / "transforms.json") << json.dump(); };

  Json fisheye = top;
  fisheye["camera_model"] = "OPENCV_FISHEYE";
  rewrite(fisheye);
  std::string message = errorOf([&] { loadDataset(folder.string(), options); });
  EXPECT_NE(message.find("OPENCV_FISHEYE"), std::string::npos) << message;
  EXPECT_NE(message.find("Undistort"), std::string::npos) << message;
  EXPECT_NE(message.find("PINHOLE"), std::string::npos) << message;

  Json k3 = top;
  k3["frames"][1]["k3"] = 0.05;
  rewrite(k3);
  message = errorOf([&] { loadDataset(folder.string(), options); });
  EXPECT_NE(message.find("frames[1] has k3"), std::string::npos) << message;

  Json bad = top;
  bad["applied_transform"] = Json::array({{1, 0, 0, 0}, {0, 1, 0, 0}});
  rewrite(bad);
  message = errorOf([&] { loadDataset(folder.string(), options); });
  EXPECT_NE(message.find("applied_transform must be a 3x4"), std::string::npos) << message;

  Json no_focal = top;
  no_focal.erase("fl_x");
  no_focal.erase("fl_y");
  rewrite(no_focal);
  message = errorOf([&] { loadDataset(folder.string(), options); });
  EXPECT_NE(message.find("no focal length"), std::string::npos) << message;
  EXPECT_NE(message.find("nerfstudio"), std::string::npos) << message;
}

TEST(DatasetLayouts, OtherFoldersSayWhatTheyHoldAndWhatIsAccepted) {
  const fs::path folder = freshFolder("other");
  auto message = [&] { return errorOf([&] { loadDataset(folder.string()); }); };
  std::string text = message();
  EXPECT_NE(text.find("neither images nor a pose file"), std::string::npos) << text;
  EXPECT_NE(text.find("instant-ngp transforms.json"), std::string::npos) << text;
  EXPECT_NE(text.find("NeRF-synthetic"), std::string::npos) << text;

  fs::create_directories(folder / "images");
  writeImagePng((folder / "images" / "a.jpg").string(), cv::Mat(4, 4, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5)));
  text = message();
  EXPECT_NE(text.find("1 images but no camera poses"), std::string::npos) << text;

  std::ofstream(folder / "cameras.json") << "{}";
  text = message();
  EXPECT_NE(text.find("cameras.json"), std::string::npos) << text;

  std::ofstream(folder / "poses_bounds.npy") << "x";
  EXPECT_NE(message().find("LLFF"), std::string::npos);

  fs::create_directories(folder / "sparse" / "0");
  std::ofstream(folder / "sparse" / "0" / "cameras.bin") << "x";
  EXPECT_NE(message().find("COLMAP model"), std::string::npos);
}
