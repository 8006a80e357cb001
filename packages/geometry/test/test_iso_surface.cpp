#include <gtest/gtest.h>

#include <functional>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/iso_surface.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

DensityGrid sampleDensity(const std::function<double(const Eigen::Vector3d&)>& density, const Eigen::Vector3d& lo,
                          double spacing, int n) {
  DensityGrid grid;
  grid.dims = Eigen::Vector3i::Constant(n);
  grid.origin = lo;
  grid.spacing = Eigen::Vector3d::Constant(spacing);
  grid.values.resize(static_cast<std::size_t>(n) * n * n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) grid.values[grid.index(i, j, k)] = static_cast<float>(density(grid.node(i, j, k)));
  return grid;
}

// A NeRF-like density: high inside, falling to zero across a shell around radius R.
double sphereDensity(const Eigen::Vector3d& p, const Eigen::Vector3d& centre, double radius) {
  return std::max(0.0, 2.5 + 20.0 * (radius - (p - centre).norm()));
}

TEST(IsoSurface, SphereDensityGivesTheSphereVolume) {
  const double radius = 0.8;
  const auto grid = sampleDensity([&](const Eigen::Vector3d& p) { return sphereDensity(p, Eigen::Vector3d::Zero(), radius); },
                                  Eigen::Vector3d::Constant(-1.0), 2.0 / 47, 48);
  MeshExtractionConfig config;  // the default: density threshold 2.5, the surface at r = R
  ASSERT_EQ(config.surface, SurfaceDefinition::kDensity);
  const MeshExtractionResult result = extractMesh(grid, config);
  EXPECT_TRUE(result.closed);
  EXPECT_EQ(result.repair.components_removed, 0u);
  EXPECT_FALSE(result.repair.flipped);  // already outward
  EXPECT_NEAR(result.volume / (4.0 / 3.0 * M_PI * std::pow(radius, 3)), 1.0, 0.01);
  EXPECT_NEAR(result.area / (4.0 * M_PI * radius * radius), 1.0, 0.03);
  EXPECT_EQ(result.vertices, result.mesh.vertices.size());
  for (const auto& v : result.mesh.vertices) EXPECT_NEAR(v.norm(), radius, 0.01);
  // A sampler-grade mesh: the inside test accepts it.
  const InsideTest inside(result.mesh);
  EXPECT_TRUE(inside.inside(Eigen::Vector3d(0.1, 0.2, -0.3)));
  EXPECT_FALSE(inside.inside(Eigen::Vector3d(0.7, 0.7, 0.0)));
}

TEST(IsoSurface, BoxDensityAndSmoothing) {
  // An indicator of [-0.5, 0.5]^2 x [-0.25, 0.25] (density 10 inside, 0 outside), threshold 5:
  // the iso-surface sits halfway between nodes, so on a grid aligned with the box faces at
  // half-steps it reproduces the box exactly.
  const double h = 0.05;
  const auto grid = sampleDensity(
      [](const Eigen::Vector3d& p) {
        return (std::abs(p.x()) < 0.5 && std::abs(p.y()) < 0.5 && std::abs(p.z()) < 0.25) ? 10.0 : 0.0;
      },
      Eigen::Vector3d::Constant(-0.8 + h / 2), h, 32);
  MeshExtractionConfig config;
  config.threshold = 5.0;
  const MeshExtractionResult result = extractMesh(grid, config);
  EXPECT_TRUE(result.closed);
  EXPECT_NEAR(result.volume, 0.5, 0.5 * 0.03);
  config.repair.smoothing_iterations = 10;
  const MeshExtractionResult smooth = extractMesh(grid, config);
  EXPECT_TRUE(smooth.closed);
  EXPECT_NEAR(smooth.volume, 0.5, 0.5 * 0.05);  // Taubin keeps the volume
}

TEST(IsoSurface, KeepsTheLargestComponentAndClosesAtTheGridBorder) {
  const auto grid = sampleDensity(
      [](const Eigen::Vector3d& p) {
        return std::max(sphereDensity(p, Eigen::Vector3d(-0.4, 0, 0), 0.5), sphereDensity(p, Eigen::Vector3d(0.75, 0, 0), 0.15));
      },
      Eigen::Vector3d::Constant(-1.0), 2.0 / 39, 40);
  MeshExtractionConfig config;
  const MeshExtractionResult result = extractMesh(grid, config);
  EXPECT_EQ(result.repair.components_removed, 1u);
  EXPECT_NEAR(result.volume / (4.0 / 3.0 * M_PI * 0.125), 1.0, 0.02);
  // A body cut by the grid border is closed by the empty space outside it.
  const auto cut = sampleDensity([](const Eigen::Vector3d&) { return 10.0; }, Eigen::Vector3d::Zero(), 0.1, 11);
  const MeshExtractionResult box = extractMesh(cut, config);
  EXPECT_TRUE(box.closed);
  EXPECT_GT(box.volume, 1.0);
}

TEST(IsoSurface, ThresholdOutsideTheDensityRangeIsAnError) {
  const auto grid = sampleDensity([](const Eigen::Vector3d&) { return 1.0; }, Eigen::Vector3d::Zero(), 0.1, 4);
  MeshExtractionConfig config;
  config.threshold = 2.5;
  try {
    extractMesh(grid, config);
    FAIL() << "expected an error";
  } catch (const core::Error& error) {
    EXPECT_NE(std::string(error.what()).find("2.5"), std::string::npos) << error.what();
  }
  DensityGrid bad = grid;
  bad.values.pop_back();
  EXPECT_THROW(extractMesh(bad, config), core::Error);
  EXPECT_NEAR(densityForOpacity(0.5, 0.01), std::log(2.0) / 0.01, 1e-9);
  EXPECT_THROW(densityForOpacity(1.0, 0.01), core::Error);
}

TEST(MeshRepair, FillsHolesAndTurnsFacesOutward) {
  auto sphere = flippedFaces(testing::makeIcosphere(1.0, 3));
  const double volume = testing::polyhedronVolume(testing::makeIcosphere(1.0, 3));
  sphere.faces.erase(sphere.faces.begin() + 10);
  sphere.faces.erase(sphere.faces.begin() + 500);
  EXPECT_FALSE(analyzeMesh(sphere).closed());
  MeshRepairReport report;
  const auto repaired = repairMesh(sphere, {}, &report);
  const MeshSummary s = analyzeMesh(repaired);
  EXPECT_TRUE(s.closed());
  EXPECT_EQ(report.holes_filled, 2u);
  EXPECT_TRUE(report.flipped);
  EXPECT_NEAR(s.signed_volume / volume, 1.0, 0.005);
  EXPECT_THROW(repairMesh(core::TriangleMesh{}), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
