#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"
#include "demnerf/geometry/solid_body.hpp"

namespace demnerf::geometry {
namespace {

// A sponge in miniature: a ball of radius 0.3 bored through along x by a tunnel of radius 0.04
// (below its centre), with a closed cavity of radius 0.08 above its centre - what a NeRF's
// interior looks like at a density level, one handle and one void instead of hundreds.
constexpr double kBall = 0.3, kTunnel = 0.04, kCavity = 0.08;
// The density rises linearly with depth into the body (2.5 at its surface, 1000 per unit), so
// the extracted surface is where the shapes are, not half a cell out as a step's would be.
DensityFunction body(bool tunnel, bool cavity) {
  return [=](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
      double depth = kBall - p.norm();
      if (tunnel) depth = std::min(depth, std::hypot(p.y(), p.z() + 0.12) - kTunnel);
      if (cavity) depth = std::min(depth, (p - Eigen::Vector3d(0, 0, 0.12)).norm() - kCavity);
      sigma[i] = static_cast<float>(2.5 + 1000.0 * depth);
    }
  };
}

const Eigen::AlignedBox3d kBox(Eigen::Vector3d::Constant(-0.4), Eigen::Vector3d::Constant(0.4));
constexpr int kResolution = 64;  // cells of 0.0125: the tunnel is 6.4 cells across
const double kBallVolume = 4.0 / 3.0 * M_PI * std::pow(kBall, 3);

MeshExtractionConfig densitySurface(double solid_radius, bool keep_largest) {
  MeshExtractionConfig config;
  config.surface = SurfaceDefinition::kDensity;
  config.threshold = 2.5;
  config.solid.radius = solid_radius;
  config.repair.keep_largest_component = keep_largest;
  return config;
}

TEST(SolidBody, TunnelAndCavityOfABallBecomeSolid) {
  const DensityGrid grid = sampleDensityInBox(body(true, true), kBox, kResolution);
  // Without it: the outer surface has the tunnel's handle, the cavity is a second shell inside.
  const MeshExtractionResult sponge = extractMesh(grid, densitySurface(0.0, false));
  const SurfaceTopology before = surfaceTopology(sponge.mesh);
  EXPECT_EQ(before.components, 2u);
  EXPECT_EQ(before.genus, 1);
  const double hollow = kBallVolume - M_PI * kTunnel * kTunnel * 2 * std::sqrt(kBall * kBall - 0.12 * 0.12) -
                        4.0 / 3.0 * M_PI * std::pow(kCavity, 3);
  EXPECT_NEAR(sponge.volume, hollow, 0.03 * hollow);
  // A closing of radius 0.06 (4.8 cells) shuts the tunnel (radius 0.04); the cavity (radius 0.08)
  // survives the closing and is filled by the flood from the border.
  const MeshExtractionResult solid = extractMesh(grid, densitySurface(0.06, false));
  const SurfaceTopology after = surfaceTopology(solid.mesh);
  EXPECT_EQ(after.components, 1u);
  EXPECT_EQ(after.euler, 2);
  EXPECT_EQ(after.genus, 0);
  EXPECT_TRUE(solid.closed);
  EXPECT_NEAR(solid.volume, kBallVolume, 0.03 * kBallVolume);
  EXPECT_GT(solid.solid.closed_nodes, 0u);
  EXPECT_GT(solid.solid.cavity_nodes, 0u);
  EXPECT_NEAR(solid.solid.radius_cells, 0.06 / grid.spacing.maxCoeff(), 1e-9);
  // The cavity's nodes: about its volume over a cell's.
  const double cavity_nodes = 4.0 / 3.0 * M_PI * std::pow(kCavity, 3) / std::pow(grid.spacing.x(), 3);
  EXPECT_NEAR(static_cast<double>(solid.solid.cavity_nodes), cavity_nodes, 0.25 * cavity_nodes);
}

TEST(SolidBody, ClosingNarrowerThanTheTunnelLeavesItOpen) {
  // Radius 0.025 < the tunnel's 0.04: the handle stays, only the cavity is filled.
  const DensityGrid grid = sampleDensityInBox(body(true, true), kBox, kResolution);
  const MeshExtractionResult result = extractMesh(grid, densitySurface(0.025, false));
  const SurfaceTopology topology = surfaceTopology(result.mesh);
  EXPECT_EQ(topology.components, 1u);
  EXPECT_EQ(topology.genus, 1);
  EXPECT_GT(result.solid.cavity_nodes, 0u);
}

TEST(SolidBody, PlainBallIsUnchanged) {
  const DensityGrid grid = sampleDensityInBox(body(false, false), kBox, kResolution);
  const MeshExtractionResult plain = extractMesh(grid, densitySurface(0.0, true));
  const MeshExtractionResult solid = extractMesh(grid, densitySurface(0.06, true));
  EXPECT_EQ(surfaceTopology(solid.mesh).genus, 0);
  EXPECT_NEAR(solid.volume, plain.volume, 0.002 * plain.volume);
  EXPECT_NEAR(solid.area, plain.area, 0.002 * plain.area);
  EXPECT_EQ(solid.solid.cavity_nodes, 0u);
  // A convex body is its own closing; the few nodes it adds sit in the lattice's stair-steps.
  EXPECT_LT(solid.solid.closed_nodes, 0.002 * kBallVolume / std::pow(grid.spacing.x(), 3));
}

TEST(SolidBody, BoxedBodyIsNotErodedWhereTheBoxCutsIt) {
  // The box cuts the ball at z = -0.2 (as the fox's plaque is cut): the closing neither grows a
  // skirt along the cut nor eats into it, so the capped volume is the same with and without.
  const Eigen::AlignedBox3d cut(Eigen::Vector3d(-0.4, -0.4, -0.2), Eigen::Vector3d(0.4, 0.4, 0.4));
  const DensityGrid grid = sampleDensityInBox(body(false, false), cut, kResolution);
  const MeshExtractionResult plain = isolateObject(grid, densitySurface(0.0, true));
  const MeshExtractionResult solid = isolateObject(grid, densitySurface(0.06, true));
  EXPECT_TRUE(solid.closed);
  EXPECT_NEAR(solid.volume, plain.volume, 0.005 * plain.volume);
}

TEST(SolidBody, ShellSeenFromOneSideIsFilledBehindUpToTheBox) {
  // A dome (a spherical shell 0.04 thick, x > 0 only) open towards -x, as a one-sided capture
  // sees a head on a wall: the closing cannot shut its 0.6-wide mouth, the fill behind it can.
  const DensityFunction dome = [](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
      const double depth = std::min({0.02 - std::abs(p.norm() - 0.28), p.x()});
      sigma[i] = static_cast<float>(2.5 + 1000.0 * depth);
    }
  };
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-0.1, -0.4, -0.4), Eigen::Vector3d(0.4, 0.4, 0.4));
  const DensityGrid grid = sampleDensityInBox(dome, box, kResolution);
  const double shell = 2.0 / 3.0 * M_PI * (std::pow(0.3, 3) - std::pow(0.26, 3));
  const MeshExtractionResult closed_only = isolateObject(grid, densitySurface(0.06, true));
  EXPECT_NEAR(closed_only.volume, shell, 0.1 * shell);
  MeshExtractionConfig config = densitySurface(0.06, true);
  config.solid.behind = Eigen::Vector3d(2.0, 0.0, 0.0);  // any length
  const MeshExtractionResult filled = isolateObject(grid, config);
  // The half ball and, behind its rim, a cylinder of radius 0.3 back to the box's face at -0.1
  // (capped a cell inside it: the border layer stays empty).
  const double h = grid.spacing.x();
  const double solid = 2.0 / 3.0 * M_PI * std::pow(0.3, 3) + M_PI * 0.09 * (0.1 - h);
  EXPECT_NEAR(filled.volume, solid, 0.03 * solid);
  EXPECT_EQ(filled.topology.genus, 0);
  EXPECT_EQ(filled.topology.components, 1u);
  EXPECT_GT(filled.solid.hidden_nodes, 0u);
}

TEST(SolidBody, DistanceTransformIsExact) {
  DensityGrid grid;
  grid.dims = Eigen::Vector3i(9, 7, 5);
  grid.spacing = Eigen::Vector3d(0.5, 1.0, 2.0);
  grid.values.assign(9 * 7 * 5, 0.0f);
  std::vector<char> feature(grid.values.size(), 0);
  feature[grid.index(2, 3, 1)] = 1;
  feature[grid.index(8, 0, 4)] = 1;
  const std::vector<double> d2 = squaredDistanceTo(grid, feature);
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 7; ++j)
      for (int i = 0; i < 9; ++i) {
        const Eigen::Vector3d p = grid.node(i, j, k);
        const double a = (p - grid.node(2, 3, 1)).squaredNorm(), b = (p - grid.node(8, 0, 4)).squaredNorm();
        EXPECT_NEAR(d2[grid.index(i, j, k)], std::min(a, b), 1e-9) << i << ' ' << j << ' ' << k;
      }
  EXPECT_GT(squaredDistanceTo(grid, std::vector<char>(grid.values.size(), 0))[0], 1e29);
}

TEST(SolidBody, NegativeRadiusIsRefused) {
  const DensityGrid grid = sampleDensityInBox(body(false, false), kBox, 16);
  EXPECT_THROW(solidifyField(grid, 2.5, SolidConfig{-0.1}), core::Error);
  SolidConfig nan_direction;
  nan_direction.behind = Eigen::Vector3d(std::nan(""), 0, 1);
  EXPECT_THROW(solidifyField(grid, 2.5, nan_direction), core::Error);
  EXPECT_THROW(extractMesh(grid, densitySurface(std::nan(""), true)), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
