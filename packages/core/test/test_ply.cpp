#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"

using namespace demnerf::core;
namespace fs = std::filesystem;

namespace {

std::string temporaryPath(const std::string& name) {
  return (fs::temp_directory_path() / ("demnerf_test_" + name)).string();
}

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST(Ply, ParticlesRoundTripEveryField) {
  ParticleCloud cloud;
  cloud.resize(3);
  cloud.positions = {{0.1, 0.2, 0.3}, {-1, 0, 2}, {0.5, 0.25, -0.125}};
  cloud.volumes = {1e-6, 2e-6, 0};
  cloud.normals[2] = {0, 0, 1};
  cloud.areas = {0, 0, 4e-4};
  cloud.colors[1] = {10, 20, 30};
  const std::string path = temporaryPath("particles.ply");
  writeParticles(path, cloud);
  const ParticleCloud back = readParticles(path);
  ASSERT_EQ(back.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_TRUE(back.positions[i].isApprox(cloud.positions[i], 1e-6));
    EXPECT_NEAR(back.volumes[i], cloud.volumes[i], 1e-12);
    EXPECT_NEAR(back.areas[i], cloud.areas[i], 1e-9);
    EXPECT_EQ(back.colors[i], cloud.colors[i]);
  }
  EXPECT_TRUE(back.isSurface(2));
  EXPECT_FALSE(back.isSurface(0));
}

// Builders of synthetic bodies append particle by particle; every field must grow in step, or
// validate() (and every reader of the cloud) would see rows that do not line up.
TEST(ParticleCloud, AppendGrowsEveryFieldInStep) {
  ParticleCloud cloud;
  cloud.resize(1);
  cloud.append({0.1, 0, 0}, 1e-6, Eigen::Vector3d::Zero(), 0.0);
  cloud.append({0.2, 0, 0}, 0.0, {0, 0, 1}, 4e-4);
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_NO_THROW(cloud.validate());
  EXPECT_FALSE(cloud.isSurface(1));
  EXPECT_TRUE(cloud.isSurface(2));
  EXPECT_EQ(cloud.normals[2], Eigen::Vector3d(0, 0, 1));
  EXPECT_DOUBLE_EQ(cloud.volumes[1], 1e-6);
  EXPECT_EQ(cloud.colors[2], cloud.colors[0]);  // grey, as resize() fills
}

TEST(Ply, ResultRoundTripAndAsciiMeshes) {
  ResultField result;
  result.resize(2);
  result.positions[1] = {1, 2, 3};
  result.displacements[1] = {0.01, -0.02, 0.03};
  result.von_mises = {5.0, 1e4};
  const std::string path = temporaryPath("result.ply");
  writeResult(path, result);
  const ResultField back = readResult(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_TRUE(back.displacements[1].isApprox(result.displacements[1], 1e-6));
  EXPECT_NEAR(back.von_mises[1], 1e4, 1e-3);

  const std::string ascii = temporaryPath("quad.ply");
  std::ofstream(ascii) << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                          "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  const TriangleMesh quad = readMesh(ascii);
  EXPECT_EQ(quad.vertices.size(), 4u);
  ASSERT_EQ(quad.faces.size(), 2u);  // the quad is fanned into two triangles
  const std::string binary = temporaryPath("quad_binary.ply");
  writeMesh(binary, quad);
  const TriangleMesh again = readMesh(binary);
  EXPECT_EQ(again.faces, quad.faces);
}

TEST(Ply, ObjMeshesFromSharedData) {
  const fs::path spot = fs::path(DEMNERF_SHARED_DIR) / "data" / "meshes" / "spot.obj";
  if (!fs::exists(spot)) GTEST_SKIP() << "../shared/data/meshes is absent; skipping the OBJ check";
  const TriangleMesh mesh = readMesh(spot.string());
  EXPECT_EQ(mesh.vertices.size(), 2930u);
  EXPECT_EQ(mesh.faces.size(), 5856u);
}

TEST(Ply, MalformedFilesNameTheProblem) {
  const std::string path = temporaryPath("bad.ply");
  std::ofstream(path) << "not a ply\n";
  EXPECT_NE(errorOf([&] { readParticles(path); }).find("not a PLY"), std::string::npos);

  std::ofstream(path) << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n0 0 0\n1 1 1\n";
  EXPECT_NE(errorOf([&] { readParticles(path); }).find("'volume'"), std::string::npos);

  ParticleCloud cloud;
  cloud.resize(100);
  const std::string truncated = temporaryPath("truncated.ply");
  writeParticles(truncated, cloud);
  fs::resize_file(truncated, fs::file_size(truncated) - 10);
  EXPECT_NE(errorOf([&] { readParticles(truncated); }).find("truncated"), std::string::npos);

  const std::string obj = temporaryPath("bad.obj");
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nf 1 2 3\n";
  EXPECT_NE(errorOf([&] { readMesh(obj); }).find("out of range"), std::string::npos);

  cloud.positions[3].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf([&] { writeParticles(truncated, cloud); }).find("NaN"), std::string::npos);
}
