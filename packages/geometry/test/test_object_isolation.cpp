#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/object_isolation.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

// A synthetic capture: a table slab under the whole scene, a figure (ball of radius 0.15) standing
// on it, a second ball of the same size beside it, and a small floater above the figure.
constexpr double kRadius = 0.15;
bool inBall(const float* p, double cx, double cz, double r) {
  const double dx = p[0] - cx, dy = p[1], dz = p[2] - cz;
  return dx * dx + dy * dy + dz * dz <= r * r;
}
DensityFunction scene(bool with_neighbour, bool with_floater) {
  return [=](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const float* p = points + 3 * i;
      const bool table = p[2] >= -0.30 && p[2] <= -0.25;
      const bool figure = inBall(p, 0.0, -0.1, kRadius);
      const bool neighbour = with_neighbour && inBall(p, 0.5, -0.1, kRadius);
      const bool floater = with_floater && inBall(p, 0.0, 0.2, 0.04);
      sigma[i] = table || figure || neighbour || floater ? 200.0f : 0.0f;
    }
  };
}

MeshExtractionConfig densitySurface() {
  MeshExtractionConfig config;
  config.surface = SurfaceDefinition::kDensity;
  config.threshold = 2.5;
  return config;
}

// Above the table top (z = -0.25), around the figure only.
const Eigen::AlignedBox3d kFigureBox(Eigen::Vector3d(-0.25, -0.25, -0.24), Eigen::Vector3d(0.25, 0.25, 0.1));

TEST(ObjectIsolation, BoxAboveTheTableGivesTheFigureAloneClosedAndCappedFlat) {
  for (SurfaceDefinition surface : {SurfaceDefinition::kDensity, SurfaceDefinition::kOpacity}) {
    MeshExtractionConfig config = densitySurface();
    config.surface = surface;
    config.opacity = 0.5;
    IsolationReport report;
    const DensityGrid grid = sampleDensityInBox(scene(false, false), kFigureBox, 64);
    const MeshExtractionResult result = isolateObject(grid, config, {}, &report);
    EXPECT_TRUE(result.closed);
    EXPECT_EQ(report.pieces, 1u);
    const MeshSummary summary = analyzeMesh(result.mesh);
    // No table: the mesh is as wide as the ball, not the scene; its base is the box's cut.
    EXPECT_LT(summary.bounds.sizes().x(), 2 * kRadius + 0.02);
    EXPECT_GT(summary.bounds.min().z(), -0.25);
    // The ball above z = -0.24 (a cap of height 0.01 is cut off): about 4/3 pi r^3; the step
    // from 200 to 0 puts the surface up to half a cell (0.004) out, +8 % on this ball.
    const double ball = 4.0 / 3.0 * M_PI * std::pow(kRadius, 3);
    EXPECT_NEAR(result.volume, ball, 0.12 * ball);
  }
}

TEST(ObjectIsolation, TheWholeSceneWithoutABoxIsTheTable) {
  // What the box is for: the scene's largest piece is the table with the figure on it.
  const Eigen::AlignedBox3d scene_box(Eigen::Vector3d(-1, -1, -0.4), Eigen::Vector3d(1, 1, 0.4));
  const MeshExtractionResult result =
      isolateObject(sampleDensityInBox(scene(false, false), scene_box, 64), densitySurface());
  EXPECT_GT(analyzeMesh(result.mesh).bounds.sizes().x(), 1.5);
}

TEST(ObjectIsolation, EmptyBoxIsRefusedNamingTheBoxAndTheFrame) {
  const Eigen::AlignedBox3d air(Eigen::Vector3d(0.6, 0.6, 0.2), Eigen::Vector3d(0.9, 0.9, 0.4));
  try {
    isolateObject(sampleDensityInBox(scene(true, true), air, 32), densitySurface());
    FAIL() << "an empty box must be refused";
  } catch (const core::Error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("is empty"), std::string::npos) << message;
    EXPECT_NE(message.find("model's frame"), std::string::npos) << message;
  }
}

TEST(ObjectIsolation, TwoComparablePiecesAreRefusedWithTheirCount) {
  const Eigen::AlignedBox3d both(Eigen::Vector3d(-0.25, -0.25, -0.24), Eigen::Vector3d(0.75, 0.25, 0.1));
  const DensityGrid grid = sampleDensityInBox(scene(true, false), both, 64);
  try {
    isolateObject(grid, densitySurface());
    FAIL() << "two objects in one box must be refused";
  } catch (const core::Error& error) {
    EXPECT_NE(std::string(error.what()).find("holds 2 separate pieces"), std::string::npos) << error.what();
  }
  // Asked to keep the largest whatever the rest, it meshes one ball.
  IsolationConfig lenient;
  lenient.max_second_piece_fraction = 1.01;
  IsolationReport report;
  const MeshExtractionResult result = isolateObject(grid, densitySurface(), lenient, &report);
  EXPECT_EQ(report.pieces, 2u);
  EXPECT_LT(analyzeMesh(result.mesh).bounds.sizes().x(), 2 * kRadius + 0.03);
}

TEST(ObjectIsolation, SmallFloatersAreDroppedAndCounted) {
  const Eigen::AlignedBox3d tall(Eigen::Vector3d(-0.25, -0.25, -0.24), Eigen::Vector3d(0.25, 0.25, 0.3));
  IsolationReport report;
  const MeshExtractionResult result =
      isolateObject(sampleDensityInBox(scene(false, true), tall, 64), densitySurface(), {}, &report);
  EXPECT_EQ(report.pieces, 2u);
  EXPECT_GT(report.nodes_dropped, 0u);
  EXPECT_LT(report.piece_nodes[1], report.piece_nodes[0] / 10);
  EXPECT_LT(analyzeMesh(result.mesh).bounds.max().z(), 0.06);  // the floater (z 0.16..0.24) is gone
}

TEST(ObjectIsolation, AnOpenSurfaceIsRefusedWithItsEdgeCounts) {
  // Marching on a grid closed at the box's faces cannot leave holes; a mesh from elsewhere (a
  // scan, or a surface cut by hand) can, and the sampler needs a closed body.
  const core::TriangleMesh closed = testing::makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  EXPECT_NO_THROW(requireClosedIsolation(closed));
  core::TriangleMesh open = closed;
  open.faces.pop_back();  // one triangle missing: three boundary edges
  try {
    requireClosedIsolation(open);
    FAIL() << "an open mesh must be refused";
  } catch (const core::Error& error) {
    EXPECT_NE(std::string(error.what()).find("open (3 boundary"), std::string::npos) << error.what();
  }
}

TEST(ObjectIsolation, ParseBoxAcceptsSixOrderedNumbersOnly) {
  const Eigen::AlignedBox3d box = parseBox("-0.1,-0.2,-0.3,0.1,0.2,0.3");
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(-0.1, -0.2, -0.3)));
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_EQ(parseBox(formatBox(box)).max(), box.max());
  EXPECT_THROW(parseBox("0,0,0,1,1"), core::Error);
  EXPECT_THROW(parseBox("0,0,0,1,1,x"), core::Error);
  EXPECT_THROW(parseBox("0,0,0,1,1,1x"), core::Error);
  EXPECT_THROW(parseBox("0,0,1,1,1,0"), core::Error);  // zmin > zmax
  EXPECT_THROW(parseBox("0,0,0,1,1,nan"), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
