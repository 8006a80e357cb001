#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/pose.hpp"

using namespace demnerf::core;
namespace fs = std::filesystem;

namespace {

fs::path freshFolder(const std::string& name) {
  const fs::path folder = fs::temp_directory_path() / ("demnerf_test_" + name);
  fs::remove_all(folder);
  fs::create_directories(folder);
  return folder;
}

void writeText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST(Dataset, FoxLoadsWithFiftyFramesAndTheFilesIntrinsics) {
  const fs::path fox = fs::path(DEMNERF_SHARED_DIR) / "data" / "fox";
  if (!fs::exists(fox / "transforms.json")) GTEST_SKIP() << "../shared/data/fox is absent; skipping the fox check";
  DatasetOptions options;
  options.load_images = false;
  const Dataset dataset = loadDataset(fox.string(), options);
  EXPECT_EQ(dataset.train.size() + dataset.test.size(), 50u);
  EXPECT_EQ(dataset.test.size(), 7u);  // frames 0, 8, ..., 48
  const PinholeCamera& camera = dataset.train.front().camera;
  EXPECT_EQ(camera.width, 1080);
  EXPECT_EQ(camera.height, 1920);
  EXPECT_NEAR(camera.fx, 1375.52, 0.01);
  EXPECT_NEAR(camera.cy, 965.268, 1e-6);
  EXPECT_EQ(dataset.missing_images.size(), 17u);  // the file lists 67 frames for 50 photos
  EXPECT_NE(camera.k1, 0.0);
  EXPECT_DOUBLE_EQ(dataset.aabb_scale, 4.0);
  // Every camera looks roughly at the middle of the scene box.
  const Eigen::Vector3d centre = dataset.bounds.center();
  for (const Frame& frame : dataset.train) {
    const Eigen::Vector3d to_centre = (centre - frame.world_from_camera.translation()).normalized();
    EXPECT_GT(to_centre.dot(frame.world_from_camera.linear().col(2)), 0.5) << frame.file_path;
  }
}

TEST(Dataset, FoxImagesLoadDownscaled) {
  const fs::path fox = fs::path(DEMNERF_SHARED_DIR) / "data" / "fox";
  if (!fs::exists(fox / "transforms.json")) GTEST_SKIP() << "../shared/data/fox is absent; skipping the fox check";
  DatasetOptions options;
  options.downscale = 8.0;
  const Dataset dataset = loadDataset(fox.string(), options);
  const Frame& frame = dataset.train.front();
  EXPECT_EQ(frame.rgba.cols, frame.camera.width);
  EXPECT_EQ(frame.rgba.rows, 240);
  EXPECT_EQ(frame.rgba.type(), CV_32FC4);
  EXPECT_FALSE(frame.has_alpha);
}

TEST(Dataset, WrittenTransformsReadBackWithTheSamePosesAndAlpha) {
  const fs::path folder = freshFolder("roundtrip");
  std::vector<Frame> frames;
  for (int i = 0; i < 3; ++i) {
    Frame frame;
    frame.file_path = "r_" + std::to_string(i) + ".png";
    frame.camera.width = 8;
    frame.camera.height = 6;
    frame.camera.fx = frame.camera.fy = 10.0;
    frame.camera.cx = 4.0;
    frame.camera.cy = 3.0;
    frame.world_from_camera.linear() = Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
    frame.world_from_camera.translation() = Eigen::Vector3d(i, 2.0, -1.0);
    cv::Mat image(6, 8, CV_32FC4, cv::Scalar(1.0, 0.0, 0.0, 0.0));
    image.at<cv::Vec4f>(2, 3) = cv::Vec4f(0.0f, 1.0f, 0.0f, 1.0f);
    writeImagePng((folder / frame.file_path).string(), image);
    frames.push_back(frame);
  }
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 2, 3));
  writeTransforms((folder / "transforms_train.json").string(), frames, box);
  const Dataset dataset = loadDataset(folder.string());
  ASSERT_EQ(dataset.train.size(), 3u);
  EXPECT_TRUE(dataset.test.empty());
  EXPECT_TRUE(dataset.bounds.max().isApprox(box.max()));
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(dataset.train[i].world_from_camera.isApprox(frames[i].world_from_camera, 1e-9));
    EXPECT_TRUE(dataset.train[i].has_alpha);
  }
  const cv::Vec4f pixel = dataset.train[0].rgba.at<cv::Vec4f>(2, 3);
  EXPECT_FLOAT_EQ(pixel[1], 1.0f);
  EXPECT_FLOAT_EQ(pixel[3], 1.0f);
  EXPECT_FLOAT_EQ(dataset.train[0].rgba.at<cv::Vec4f>(0, 0)[3], 0.0f);
}

TEST(Dataset, MalformedFilesNameTheProblem) {
  const fs::path folder = freshFolder("malformed");
  EXPECT_NE(errorOf([&] { loadDataset(folder.string()); }).find("no transforms.json"), std::string::npos);
  writeText(folder / "transforms.json", "{ \"frames\": [ }");
  for (const char* name : {"a.png", "b.png"}) {
    writeImagePng((folder / name).string(), cv::Mat(4, 4, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5)));
  }
  EXPECT_NE(errorOf([&] { loadDataset(folder.string()); }).find("not valid JSON"), std::string::npos);
  writeText(folder / "transforms.json",
            R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]},)"
            R"( {"file_path": "b.png", "transform_matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
  DatasetOptions options;
  options.load_images = false;
  const std::string message = errorOf([&] { loadDataset(folder.string(), options); });
  EXPECT_NE(message.find("frames[1].transform_matrix"), std::string::npos) << message;
  EXPECT_NE(message.find("rigid"), std::string::npos) << message;
  writeText(folder / "transforms.json",
            R"({"fl_x": "wide", "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
  EXPECT_NE(errorOf([&] { loadDataset(folder.string(), options); }).find("'fl_x'"), std::string::npos);
}
