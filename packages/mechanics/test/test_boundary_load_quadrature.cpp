// The FEM's surface loads follow the load region, not the mesh: a region that cuts boundary faces
// loads the part of them inside it.
#include <gtest/gtest.h>

#include "demnerf/mechanics/boundary_load_quadrature.hpp"

namespace dm = demnerf::mechanics;
using Eigen::Vector3d;

namespace {

demnerf::core::Region box(const Vector3d& center, const Vector3d& size) {
  demnerf::core::Region r;
  r.type = demnerf::core::Region::Type::kBox;
  r.center = center;
  r.size = size;
  return r;
}

struct Patch {
  double area = 0.0;
  Vector3d centroid = Vector3d::Zero();
};

Patch patch(const std::vector<dm::BoundaryLoadPoint>& points) {
  Patch p;
  for (const auto& q : points) {
    p.area += q.weight;
    p.centroid += q.weight * q.x;
  }
  if (p.area > 0) p.centroid /= p.area;
  return p;
}

}  // namespace

TEST(BoundaryLoadQuadrature, WholeFacesGiveTheFaceExactly) {
  const dm::TetMesh mesh = dm::structuredBoxMesh(Vector3d::Zero(), Vector3d::Ones(), Eigen::Vector3i(2, 2, 2), 2);
  const auto faces = dm::boundaryFaces(mesh);
  const Patch top = patch(dm::boundaryLoadQuadrature(mesh, faces, box(Vector3d(0.5, 0.5, 1.0), Vector3d(2, 2, 1e-6))));
  EXPECT_NEAR(top.area, 1.0, 1e-12);
  EXPECT_LT((top.centroid - Vector3d(0.5, 0.5, 1.0)).norm(), 1e-12);
}

TEST(BoundaryLoadQuadrature, ARegionThatCutsFacesLoadsOnlyThePartInside) {
  const dm::TetMesh mesh = dm::structuredBoxMesh(Vector3d::Zero(), Vector3d::Ones(), Eigen::Vector3i(2, 2, 2), 2);
  const auto faces = dm::boundaryFaces(mesh);
  // x in [0, 0.37] of the top face: faces of 0.5 are cut along x = 0.37 (whole faces by their
  // centroids gave 0.25 or 0.5 here).
  for (double edge : {0.37, 0.61, 0.83}) {
    const auto region = box(Vector3d(0.5 * edge, 0.5, 1.0), Vector3d(edge, 2, 1e-6));
    const Patch p = patch(dm::boundaryLoadQuadrature(mesh, faces, region));
    EXPECT_NEAR(p.area, edge, 0.01) << "edge at x = " << edge;
    EXPECT_NEAR(p.centroid.x(), 0.5 * edge, 0.005) << "edge at x = " << edge;
    EXPECT_NEAR(p.centroid.y(), 0.5, 0.005);
  }
  EXPECT_TRUE(dm::boundaryLoadQuadrature(mesh, faces, box(Vector3d(5, 5, 5), Vector3d(1, 1, 1))).empty());
}

// A face that ends the region stays loaded when the mesh went through a float32 PLY, which puts it
// a rounding step outside (the T-bar's arm ends at x = 0.15 lost their strip of load on the CLI).
TEST(BoundaryLoadQuadrature, AFaceOnTheRegionsEdgeStaysLoadedAfterRounding) {
  dm::TetMesh mesh = dm::structuredBoxMesh(Vector3d::Zero(), Vector3d::Ones(), Eigen::Vector3i(2, 2, 2), 2);
  for (auto& x : mesh.nodes)
    if (x.z() == 1.0) x.z() = static_cast<double>(1.0f + 6e-8f);
  const auto faces = dm::boundaryFaces(mesh);
  const Patch all = patch(dm::boundaryLoadQuadrature(mesh, faces, box(Vector3d(0.5, 0.5, 0.5), Vector3d(2, 2, 1))));
  EXPECT_NEAR(all.area, 6.0, 1e-5) << "the top face z = 1 + 1e-7 belongs to the region z <= 1";
}
