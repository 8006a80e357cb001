#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/render/box_mesh.hpp"
#include "demnerf/render/camera_rig.hpp"
#include "demnerf/render/scene_geometry.hpp"

namespace demnerf::render {
namespace {

double longestEdge(const core::TriangleMesh& mesh) {
  double longest = 0.0;
  for (const auto& f : mesh.faces) {
    for (int e = 0; e < 3; ++e) {
      longest = std::max(longest, (mesh.vertices[f[e]] - mesh.vertices[f[(e + 1) % 3]]).norm());
    }
  }
  return longest;
}

TEST(SceneGeometry, MeshesAreClosedOutwardAndHaveTheAnalyticVolume) {
  struct Case {
    SceneKind kind;
    double volume;
  };
  // T-bar: bar 0.30 x 0.06 x 0.06 + leg 0.06 x 0.06 x 0.24; cuboid 0.125 x 0.1 x 0.1; Cook:
  // quadrilateral of 1440 mm^2 (shoelace) times 1 mm.
  const Case cases[] = {{SceneKind::kTBar, 0.30 * 0.06 * 0.06 + 0.06 * 0.06 * 0.24},
                        {SceneKind::kCuboid, 0.125 * 0.1 * 0.1},
                        {SceneKind::kCookMembrane, 1440e-6 * 0.001}};
  for (const Case& c : cases) {
    const SceneObject object = makeSceneObject(c.kind);
    SCOPED_TRACE(sceneName(c.kind));
    EXPECT_EQ(countBoundaryOrInconsistentEdges(object.mesh), 0u);
    EXPECT_NEAR(enclosedVolume(object.mesh), c.volume, 1e-9 * c.volume + 1e-12);
    EXPECT_GT(object.mesh.faces.size(), 1000u) << "too coarse to bend smoothly";
  }
}

TEST(SceneGeometry, TBarHasThePaperDimensionsAndSubdividedFaces) {
  const auto mesh = makeTBarMesh(TBarDimensions{}, 0.01);
  Eigen::AlignedBox3d box;
  box.setEmpty();
  for (const auto& v : mesh.vertices) box.extend(v);
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(-0.15, -0.03, 0.0), 1e-12));
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(0.15, 0.03, 0.30), 1e-12));
  // Quads no longer than max_edge, split along their diagonal.
  EXPECT_LE(longestEdge(mesh), 0.01 * std::sqrt(2.0) + 1e-12);
}

TEST(SceneGeometry, CookMembraneKeepsItsCornersAndThickness) {
  const auto mesh = makeCookMembraneMesh(CookMembraneDimensions{}, 0.004);
  const Eigen::Vector3d corners[] = {{0, 0, 0}, {0.048, 0.044, 0}, {0.048, 0.060, 0.001}, {0, 0.044, 0.001}};
  for (const auto& corner : corners) {
    double nearest = 1.0;
    for (const auto& v : mesh.vertices) nearest = std::min(nearest, (v - corner).norm());
    EXPECT_LT(nearest, 1e-12) << corner.transpose();
  }
  EXPECT_EQ(countBoundaryOrInconsistentEdges(mesh), 0u);
}

TEST(SceneGeometry, UnknownSceneAndBadEdgeAreRefused) {
  EXPECT_THROW(parseSceneKind("teapot"), core::Error);
  try {
    parseSceneKind("teapot");
  } catch (const core::Error& error) {
    EXPECT_NE(std::string(error.what()).find("teapot"), std::string::npos);
  }
  EXPECT_THROW(makeTBarMesh(TBarDimensions{}, 0.0), core::Error);
  EXPECT_THROW(meshBoxUnion({}, 0.01), core::Error);
}

TEST(CameraRig, ViewsAreDistinctAndSeeTheWholeObject) {
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  CameraRigConfig config;
  const CameraRig rig = makeCameraRig(object.bounds, config);
  ASSERT_EQ(rig.train.size(), 48u);
  ASSERT_EQ(rig.test.size(), 8u);
  std::vector<Eigen::Isometry3d> all = rig.train;
  all.insert(all.end(), rig.test.begin(), rig.test.end());
  for (std::size_t i = 0; i < all.size(); ++i) {
    // Looks at the centre, from the same distance.
    const Eigen::Vector3d to_centre = object.bounds.center() - all[i].translation();
    EXPECT_NEAR(to_centre.norm(), rig.distance, 1e-9);
    EXPECT_GT(all[i].linear().col(2).dot(to_centre.normalized()), 1 - 1e-9);
    EXPECT_TRUE(all[i].linear().isUnitary(1e-9));
    EXPECT_GT(all[i].linear().determinant(), 0.0);
    for (std::size_t j = 0; j < i; ++j) {
      EXPECT_GT((all[i].translation() - all[j].translation()).norm(), 0.05 * rig.distance) << i << " " << j;
    }
    for (const auto& v : object.mesh.vertices) {
      const Eigen::Vector3d local = all[i].inverse() * v;
      ASSERT_GT(local.z(), 0.0);
      const Eigen::Vector2d pixel = rig.camera.project(local);
      EXPECT_TRUE(pixel.x() > 0 && pixel.y() > 0 && pixel.x() < config.width && pixel.y() < config.height);
    }
  }
}

TEST(CameraRig, RejectsNoViews) {
  const SceneObject object = makeSceneObject(SceneKind::kCuboid);
  CameraRigConfig config;
  config.train_views = 0;
  EXPECT_THROW(makeCameraRig(object.bounds, config), core::Error);
  config.train_views = 3;
  config.width = 0;
  EXPECT_THROW(makeCameraRig(object.bounds, config), core::Error);
}

}  // namespace
}  // namespace demnerf::render
