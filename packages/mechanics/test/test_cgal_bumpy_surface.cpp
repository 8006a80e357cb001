// The CGAL mesh of a bumpy (scanned or NeRF-extracted) surface follows the asked cell: its short
// creases are not protected as the body's edges (issue 13, the NeRF cuboid's reference).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/sharp_features.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

// The surface of the unit cube, n x n squares per face, each vertex off an edge pushed along its
// face's normal by a pseudo-random amount of up to `bump` (as a fraction of a square): the ragged
// faces of a marching-cubes extraction, with many short creases that fade out.
core::TriangleMesh bumpyCube(int n, double bump) {
  core::TriangleMesh mesh;
  std::map<std::tuple<int, int, int>, int> index;
  const auto vertex = [&](int i, int j, int k) {
    const auto [it, added] = index.emplace(std::make_tuple(i, j, k), static_cast<int>(mesh.vertices.size()));
    if (added) {
      Vector3d x(i, j, k);
      const int on_faces = (i == 0 || i == n) + (j == 0 || j == n) + (k == 0 || k == n);
      if (on_faces == 1) {  // a face's interior vertex (edges and corners stay put)
        const unsigned h = (static_cast<unsigned>(i) * 73856093u) ^ (static_cast<unsigned>(j) * 19349663u) ^
                           (static_cast<unsigned>(k) * 83492791u);
        const double r = bump * (static_cast<double>(h % 1000) / 999.0 - 0.5) * 2.0;
        const Vector3d normal((i == n) - (i == 0), (j == n) - (j == 0), (k == n) - (k == 0));
        x += r * normal;
      }
      mesh.vertices.push_back(x / n);
    }
    return it->second;
  };
  // Each face as a grid in its two in-plane axes (a, b); the fixed axis at 0 or n.
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side <= 1; ++side)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          const auto at = [&](int da, int db) {
            int c[3];
            c[axis] = side * n;
            c[(axis + 1) % 3] = a + da;
            c[(axis + 2) % 3] = b + db;
            return vertex(c[0], c[1], c[2]);
          };
          const int v00 = at(0, 0), v10 = at(1, 0), v11 = at(1, 1), v01 = at(0, 1);
          // (axis+1, axis+2) is right-handed with the axis: counter-clockwise seen from outside
          // on the upper side, so the lower side takes the reverse order.
          if (side == 1) {
            mesh.faces.push_back({v00, v10, v11});
            mesh.faces.push_back({v00, v11, v01});
          } else {
            mesh.faces.push_back({v00, v11, v10});
            mesh.faces.push_back({v00, v01, v11});
          }
        }
  return mesh;
}

TEST(CgalBumpySurface, ExactBoxCreasesAreItsTwelveEdges) {
  const std::vector<dm::SharpCurve> curves = dm::sharpCurves(dm::boxSurface(Vector3d(0, 0, 0), Vector3d(3, 2, 1)), 60);
  ASSERT_EQ(curves.size(), 12u);
  double total = 0;
  for (const dm::SharpCurve& c : curves) {
    EXPECT_FALSE(c.dangling);
    EXPECT_FALSE(c.closed);
    total += c.length;
  }
  EXPECT_NEAR(total, 4.0 * (3 + 2 + 1), 1e-12);
  dm::CgalMeshConfig config;
  EXPECT_FALSE(dm::creasesAreNoise(dm::boxSurface(Vector3d(0, 0, 0), Vector3d(3, 2, 1)), config));
}

TEST(CgalBumpySurface, MeshSizeFollowsTheCellNotTheBumps) {
  const core::TriangleMesh surface = bumpyCube(16, 0.45);
  dm::CgalMeshConfig config;
  ASSERT_TRUE(dm::creasesAreNoise(surface, config));
  config.order = 1;
  for (double cell : {0.25, 0.2}) {
    config.cell = cell;
    const dm::TetMesh mesh = dm::cgalMeshFromSurface(surface, config);
    // A Delaunay mesh of edge `cell` fills a unit volume with about 6 / cell^3 tetrahedra, more
    // near a surface followed to cell / 10 (measured: 819 at 0.25 where 384 fill it, 1,604 at 0.2).
    const double asked = 6.0 / (cell * cell * cell);
    EXPECT_LT(static_cast<double>(mesh.elements.size()), 4.0 * asked) << "cell " << cell;
    EXPECT_GT(static_cast<double>(mesh.elements.size()), 0.25 * asked) << "cell " << cell;
  }
  // The same surface with its creases protected (what the mesher did before) is far finer
  // (8,167 tetrahedra at cell 0.5, where 48 fill the cube).
  config.cell = 0.5;
  config.max_dangling_fraction = 1.0;
  ASSERT_FALSE(dm::creasesAreNoise(surface, config));
  const dm::TetMesh protected_mesh = dm::cgalMeshFromSurface(surface, config);
  EXPECT_GT(static_cast<double>(protected_mesh.elements.size()), 20.0 * 6.0 / 0.125);
}

TEST(CgalBumpySurface, BadCreaseSettingsAreReported) {
  const core::TriangleMesh box = dm::boxSurface(Vector3d(0, 0, 0), Vector3d(1, 1, 1));
  dm::CgalMeshConfig config;
  config.max_dangling_fraction = 1.5;
  EXPECT_THROW(dm::creasesAreNoise(box, config), core::Error);
  config.max_dangling_fraction = 0.25;
  config.feature_angle = -1;
  EXPECT_THROW(dm::cgalMeshFromSurface(box, config), core::Error);
}

}  // namespace
