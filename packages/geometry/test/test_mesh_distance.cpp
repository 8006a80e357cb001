#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_distance.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

TEST(MeshDistance, ConcentricSpheresAreTheirRadiiApart) {
  // Icospheres are inscribed polyhedra: compare each against its own faces' distance field,
  // so only the offset between the two counts.
  const auto inner = testing::makeIcosphere(1.0, 4);
  auto outer = inner;
  for (auto& v : outer.vertices) v *= 1.05;
  MeshDistanceConfig config;
  config.samples = 4000;
  const MeshDistance d = meshDistance(inner, outer, config);
  // Scaling by 1.05 moves a face's points by 5 % of their distance to the centre (>= the
  // inradius ~0.997), and the nearest point of the other sphere is along that normal.
  EXPECT_NEAR(d.a_to_b_mean, 0.05 * 0.998, 0.002);
  EXPECT_NEAR(d.b_to_a_mean, 0.05 * 0.998, 0.002);
  EXPECT_NEAR(d.chamfer, 0.5 * (d.a_to_b_mean + d.b_to_a_mean), 1e-12);
  EXPECT_NEAR(d.chamfer_sum, 2 * d.chamfer, 1e-12);
  EXPECT_GE(d.hausdorff, d.a_to_b_mean);
  EXPECT_LT(d.hausdorff, 0.0505);
  // Identical meshes: zero.
  EXPECT_NEAR(meshDistance(inner, inner, config).hausdorff, 0.0, 1e-9);
}

TEST(MeshDistance, AMissingPartShowsOneWay) {
  // B is A plus a second box far away: every point of A lies on B, not the other way round.
  const auto a = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  auto b = a;
  const auto far = testing::makeBox(Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(4, 1, 1));
  for (const auto& f : far.faces) b.faces.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
  b.vertices.insert(b.vertices.end(), far.vertices.begin(), far.vertices.end());
  MeshDistanceConfig config;
  config.samples = 3000;
  const MeshDistance d = meshDistance(a, b, config);
  EXPECT_NEAR(d.a_to_b_mean, 0.0, 1e-9);
  EXPECT_GT(d.b_to_a_mean, 0.5);  // half of B's points are >= 2 away from A
  EXPECT_GT(d.hausdorff, 2.0);
}

TEST(MeshDistance, SurfacePointsAreUniformAndOnTheMesh) {
  const auto box = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(2, 1, 1));
  const auto points = sampleSurfacePoints(box, 10000, 3);
  ASSERT_EQ(points.size(), 10000u);
  int on_big_faces = 0;
  for (const auto& p : points) {
    const double to_face = std::min({p.x(), 2 - p.x(), p.y(), 1 - p.y(), p.z(), 1 - p.z()});
    EXPECT_NEAR(to_face, 0.0, 1e-12);
    on_big_faces += (p.y() < 1e-12 || p.y() > 1 - 1e-12 || p.z() < 1e-12 || p.z() > 1 - 1e-12);
  }
  // 8 of the 10 m^2 lie on the four 2 x 1 faces.
  EXPECT_NEAR(on_big_faces / 10000.0, 0.8, 0.02);
  EXPECT_EQ(sampleSurfacePoints(box, 100, 5), sampleSurfacePoints(box, 100, 5));
}

TEST(MeshDistance, EmptyOrFlatMeshesAreRefused) {
  const auto box = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  try {
    meshDistance(box, core::TriangleMesh{});
    FAIL() << "empty mesh accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("second mesh has no surface"), std::string::npos) << e.what();
  }
  core::TriangleMesh flat;
  flat.vertices = {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 2 * Eigen::Vector3d::UnitX()};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(meshDistance(flat, box), core::Error);
  MeshDistanceConfig none;
  none.samples = 0;
  EXPECT_THROW(meshDistance(box, box, none), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
