#include <gtest/gtest.h>

#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/lattice_crossings.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/winding_number.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

TEST(InsideTest, AgreesWithTheSphereAwayFromTheSurface) {
  const auto sphere = testing::makeIcosphere(1.0, 3);
  const InsideTest test(sphere);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const double r = p.norm();
    if (std::abs(r - 1.0) < 0.02) continue;  // between the polyhedron and the sphere
    EXPECT_EQ(test.inside(p), r < 1.0) << p.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 1800);
  EXPECT_NEAR(test.squaredDistance(Eigen::Vector3d(3, 0, 0)), 4.0, 1e-6);
}

TEST(InsideTest, FlippedMeshGivesTheSameAnswer) {
  const auto sphere = flippedFaces(testing::makeIcosphere(1.0, 2));
  const InsideTest test(sphere);
  EXPECT_TRUE(test.inside(Eigen::Vector3d(0.2, 0.1, 0)));
  EXPECT_FALSE(test.inside(Eigen::Vector3d(1.2, 0.1, 0)));
}

TEST(InsideTest, RefusesOpenMeshes) {
  auto open = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  open.faces.erase(open.faces.begin());
  EXPECT_THROW(InsideTest{open}, core::Error);
  EXPECT_THROW(InsideTest{core::TriangleMesh{}}, core::Error);
}

TEST(LatticeCrossings, LinesThroughEdgesAndVerticesCountOnce) {
  // Lines at y, z in {0, 0.25, ..., 1} run through the cube's edges, corners and the face
  // diagonals; a double or missed crossing would flip whole rows of nodes.
  const auto cube = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  Lattice lattice;
  lattice.origin = Eigen::Vector3d(-0.35, -0.25, -0.25);
  lattice.spacing = Eigen::Vector3d(0.1, 0.25, 0.25);
  lattice.dims = Eigen::Vector3i(18, 7, 7);
  const auto inside = classifyLattice(cube, lattice);
  for (int k = 0; k < 7; ++k) {
    for (int j = 0; j < 7; ++j) {
      for (int i = 0; i < 18; ++i) {
        const Eigen::Vector3d p = lattice.node(i, j, k);
        const bool strictly_inside = (p.array() > 1e-9).all() && (p.array() < 1 - 1e-9).all();
        const bool outside = (p.array() < -1e-9).any() || (p.array() > 1 + 1e-9).any();
        if (strictly_inside) EXPECT_TRUE(inside[lattice.index(i, j, k)]) << p.transpose();
        if (outside) EXPECT_FALSE(inside[lattice.index(i, j, k)]) << p.transpose();
      }
    }
  }
  // Each line through the open square (0,1)^2 crosses the cube twice, with opposite signs.
  const auto lines = latticeLineCrossings(cube, lattice, 0);
  const auto& middle = lines[3 * 7 + 3];  // y = z = 0.5: through both x faces' diagonals
  ASSERT_EQ(middle.size(), 2u);
  EXPECT_EQ(middle[0].sign + middle[1].sign, 0);
}

TEST(LatticeCrossings, MatchesTheWindingNumberOnASphere) {
  const auto sphere = testing::makeIcosphere(1.0, 2, Eigen::Vector3d(0.013, -0.021, 0.007));
  Lattice lattice;
  lattice.origin = Eigen::Vector3d::Constant(-1.2);
  lattice.spacing = Eigen::Vector3d::Constant(0.1);
  lattice.dims = Eigen::Vector3i::Constant(25);
  const auto inside = classifyLattice(sphere, lattice);
  for (int k = 0; k < 25; ++k) {
    for (int j = 0; j < 25; ++j) {
      for (int i = 0; i < 25; ++i) {
        const Eigen::Vector3d p = lattice.node(i, j, k);
        const bool expected = windingNumber(sphere, p) > 0.5;
        EXPECT_EQ(static_cast<bool>(inside[lattice.index(i, j, k)]), expected) << p.transpose();
      }
    }
  }
}

}  // namespace
}  // namespace demnerf::geometry
