#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/render/synthetic_scene.hpp"

namespace demnerf::render {
namespace {

namespace fs = std::filesystem;

// A fresh folder under the system's temp directory, removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() / ("demnerf_render_test_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string str(const std::string& child = "") const { return (path_ / child).string(); }

 private:
  fs::path path_;
};

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

SynthConfig smallConfig(const std::string& scene, const std::string& out) {
  SynthConfig config;
  config.scene = scene;
  config.views = 3;
  config.test_views = 2;
  config.size = 40;
  config.samples_per_axis = 2;
  config.out_dir = out;
  return config;
}

// A result on grid particles inside the default cuboid with displacement u(X).
core::ResultField cuboidResult(double h, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& u) {
  core::ResultField result;
  for (double x = 0.5 * h; x < 0.125; x += h) {
    for (double y = -0.05 + 0.5 * h; y < 0.05; y += h) {
      for (double z = -0.05 + 0.5 * h; z < 0.05; z += h) {
        result.positions.emplace_back(x, y, z);
        result.displacements.push_back(u(result.positions.back()));
        result.von_mises.push_back(0.0);
      }
    }
  }
  return result;
}

TEST(SyntheticScene, WritesALoadableDatasetWithItsMesh) {
  const TempDir dir("dataset");
  const SynthFigures figures = generateSyntheticScene(smallConfig("cuboid", dir.str("out")));
  EXPECT_EQ(figures.views, 3);
  EXPECT_EQ(figures.test_views, 2);
  EXPECT_FALSE(figures.deformed);
  core::DatasetOptions options;
  const core::Dataset dataset = core::loadDataset(dir.str("out"), options);
  ASSERT_EQ(dataset.train.size(), 3u);
  ASSERT_EQ(dataset.test.size(), 2u);
  for (const auto& frame : dataset.train) {
    ASSERT_EQ(frame.rgba.rows, 40);
    EXPECT_TRUE(frame.has_alpha);
    // Transparent corner, opaque object in the middle (the camera looks at its centre).
    EXPECT_EQ(frame.rgba.at<cv::Vec4f>(0, 0)[3], 0.0f);
    EXPECT_EQ(frame.rgba.at<cv::Vec4f>(20, 20)[3], 1.0f);
  }
  const core::TriangleMesh mesh = core::readMesh(dir.str("out/mesh.ply"));
  EXPECT_EQ(mesh.faces.size(), figures.faces);
  EXPECT_FALSE(fs::exists(dir.str("out/rest_mesh.ply")));
}

TEST(SyntheticScene, SameInputsGiveBitwiseIdenticalFiles) {
  const TempDir dir("repeat");
  auto config = smallConfig("tbar", dir.str("a"));
  generateSyntheticScene(config);
  config.out_dir = dir.str("b");
  config.threads = 1;
  generateSyntheticScene(config);
  for (const std::string file : {"train/r_000.png", "train/r_002.png", "test/r_001.png", "mesh.ply",
                                 "transforms_train.json"}) {
    const std::string a = readBytes(dir.str("a/" + file));
    ASSERT_FALSE(a.empty()) << file;
    EXPECT_EQ(a, readBytes(dir.str("b/" + file))) << file;
  }
}

TEST(SyntheticScene, RendersTheBodyMovedByAResult) {
  const TempDir dir("deformed");
  const Eigen::Vector3d shift(0.0, 0.0, 0.01);
  // A rigid shift plus a small linear stretch: interpolation is exact for both.
  const auto field = [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(shift + 0.1 * p.x() * Eigen::Vector3d::UnitX()); };
  core::writeResult(dir.str("result.ply"), cuboidResult(0.01, field));
  auto config = smallConfig("cuboid", dir.str("out"));
  config.result_path = dir.str("result.ply");
  const SynthFigures figures = generateSyntheticScene(config);
  EXPECT_TRUE(figures.deformed);
  EXPECT_NEAR(figures.max_displacement, std::hypot(0.01, 0.0125), 1e-5);
  const core::TriangleMesh rest = core::readMesh(dir.str("out/rest_mesh.ply"));
  const core::TriangleMesh moved = core::readMesh(dir.str("out/mesh.ply"));
  ASSERT_EQ(rest.vertices.size(), moved.vertices.size());
  for (std::size_t i = 0; i < rest.vertices.size(); i += 97) {
    // The mesh is stored in float.
    EXPECT_LT((moved.vertices[i] - rest.vertices[i] - field(rest.vertices[i])).norm(), 1e-6);
  }
  // The cameras are the rest dataset's.
  const TempDir rest_dir("rest");
  generateSyntheticScene(smallConfig("cuboid", rest_dir.str("out")));
  EXPECT_EQ(readBytes(dir.str("out/transforms_test.json")).size() > 0, true);
  const auto a = core::loadDataset(dir.str("out"), {});
  const auto b = core::loadDataset(rest_dir.str("out"), {});
  for (std::size_t i = 0; i < a.train.size(); ++i) {
    EXPECT_TRUE(a.train[i].world_from_camera.isApprox(b.train[i].world_from_camera, 1e-6));
  }
}

TEST(SyntheticScene, BadArgumentsGiveClearErrors) {
  const TempDir dir("errors");
  const auto expectError = [](const SynthConfig& config, const std::string& fragment) {
    try {
      generateSyntheticScene(config);
      ADD_FAILURE() << "expected an error mentioning '" << fragment << "'";
    } catch (const core::Error& error) {
      EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << error.what();
    }
  };
  auto config = smallConfig("tbar", dir.str("out"));
  config.views = 0;
  expectError(config, "--views");
  config = smallConfig("sphere", dir.str("out"));
  expectError(config, "unknown scene 'sphere'");
  config = smallConfig("tbar", dir.str("out"));
  config.size = 0;
  expectError(config, "--size");

  config = smallConfig("cuboid", dir.str("out"));
  config.result_path = dir.str("missing.ply");
  expectError(config, "missing.ply");
  {
    std::ofstream garbage(dir.str("garbage.ply"));
    garbage << "this is not a ply file\n";
  }
  config.result_path = dir.str("garbage.ply");
  expectError(config, "garbage.ply");

  // A result for 1210 particles against a particle file of 3.
  const auto zero = [](const Eigen::Vector3d&) { return Eigen::Vector3d::Zero().eval(); };
  const core::ResultField result = cuboidResult(0.01, zero);
  core::writeResult(dir.str("result.ply"), result);
  core::ParticleCloud cloud;
  cloud.resize(3);
  for (std::size_t i = 0; i < 3; ++i) {
    cloud.positions[i] = result.positions[i];
    cloud.volumes[i] = 1e-6;
    cloud.normals[i] = Eigen::Vector3d::Zero();
    cloud.areas[i] = 0.0;
    cloud.colors[i] = {0, 0, 0};
  }
  core::writeParticles(dir.str("particles.ply"), cloud);
  config.result_path = dir.str("result.ply");
  config.particles_path = dir.str("particles.ply");
  expectError(config, "has " + std::to_string(result.size()) + " particles but the particle file");

  // The cuboid's result does not cover the T-bar.
  config = smallConfig("tbar", dir.str("out"));
  config.result_path = dir.str("result.ply");
  expectError(config, "tbar");
  // Only half of the cuboid's particles do not cover the cuboid.
  core::ResultField half = result;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < result.size(); ++i) {
    if (result.positions[i].x() < 0.06) {
      half.positions[kept] = result.positions[i];
      half.displacements[kept] = result.displacements[i];
      half.von_mises[kept] = 0.0;
      ++kept;
    }
  }
  half.resize(kept);
  core::writeResult(dir.str("half.ply"), half);
  config = smallConfig("cuboid", dir.str("out"));
  config.result_path = dir.str("half.ply");
  expectError(config, "does not cover the cuboid mesh");
}

}  // namespace
}  // namespace demnerf::render
