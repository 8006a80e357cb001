#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/winding_number.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

using testing::makeBox;
using testing::makeIcosphere;

std::string errorOf(const core::TriangleMesh& mesh) {
  try {
    requireClosedMesh(mesh, "test.ply");
  } catch (const core::Error& error) {
    return error.what();
  }
  return "";
}

TEST(MeshAnalysis, UnitCubeVolumeAreaAndClosed) {
  const MeshSummary s = analyzeMesh(makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  EXPECT_NEAR(s.signed_volume, 1.0, 1e-12);
  EXPECT_NEAR(s.area, 6.0, 1e-12);
  EXPECT_TRUE(s.closed());
  EXPECT_NEAR(s.diagonal(), std::sqrt(3.0), 1e-12);
}

TEST(MeshAnalysis, IcosphereApproachesTheSphere) {
  const auto mesh = makeIcosphere(2.0, 4);
  const MeshSummary s = analyzeMesh(mesh);
  EXPECT_TRUE(s.closed());
  EXPECT_NEAR(s.signed_volume, testing::polyhedronVolume(mesh), 1e-9);
  EXPECT_NEAR(s.signed_volume / (4.0 / 3.0 * M_PI * 8.0), 1.0, 0.01);
  EXPECT_NEAR(s.area / (4.0 * M_PI * 4.0), 1.0, 0.01);
}

TEST(MeshAnalysis, FlippedMeshHasNegativeVolume) {
  const MeshSummary s = analyzeMesh(flippedFaces(makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones())));
  EXPECT_NEAR(s.signed_volume, -1.0, 1e-12);
  EXPECT_TRUE(s.closed());
}

TEST(MeshAnalysis, OpenEmptyDegenerateAndFlatMeshesAreRefused) {
  auto open = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  open.faces.pop_back();
  EXPECT_EQ(analyzeMesh(open).boundary_edges, 3u);
  EXPECT_NE(errorOf(open).find("open"), std::string::npos) << errorOf(open);
  EXPECT_NE(errorOf(open).find("test.ply"), std::string::npos);

  EXPECT_NE(errorOf(core::TriangleMesh{}).find("empty"), std::string::npos);

  auto degenerate = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  degenerate.vertices[7] = degenerate.vertices[6];  // collapses the faces that use both
  EXPECT_NE(errorOf(degenerate).find("zero area"), std::string::npos) << errorOf(degenerate);

  core::TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  flat.faces = {{0, 1, 2}, {0, 2, 1}};  // closed, but encloses nothing
  EXPECT_NE(errorOf(flat).find("no volume"), std::string::npos) << errorOf(flat);

  auto misoriented = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  std::swap(misoriented.faces[0][1], misoriented.faces[0][2]);
  EXPECT_NE(errorOf(misoriented).find("oriented"), std::string::npos) << errorOf(misoriented);

  auto bad_index = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  bad_index.faces[3][1] = 99;
  EXPECT_NE(errorOf(bad_index).find("99"), std::string::npos) << errorOf(bad_index);
}

TEST(WindingNumber, OneInsideZeroOutside) {
  const auto sphere = makeIcosphere(1.0, 3);
  EXPECT_NEAR(windingNumber(sphere, Eigen::Vector3d(0.1, -0.2, 0.3)), 1.0, 1e-9);
  EXPECT_NEAR(windingNumber(sphere, Eigen::Vector3d(0.0, 0.0, 0.95)), 1.0, 1e-6);
  EXPECT_NEAR(windingNumber(sphere, Eigen::Vector3d(1.5, 0.0, 0.0)), 0.0, 1e-9);
  EXPECT_NEAR(windingNumber(flippedFaces(sphere), Eigen::Vector3d::Zero()), -1.0, 1e-9);
}

}  // namespace
}  // namespace demnerf::geometry
