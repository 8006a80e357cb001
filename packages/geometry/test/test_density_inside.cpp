#include <gtest/gtest.h>

#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_inside_test.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/optical_depth.hpp"

namespace demnerf::geometry {
namespace {

// A NeRF-like sphere: density rises linearly from 0 across a shell and equals 2.5 at r = R.
constexpr double kRadius = 0.6;
double sphereDensity(const Eigen::Vector3d& p) { return std::max(0.0, 2.5 + 40.0 * (kRadius - p.norm())); }

DensityFunction sphereFunction(int* calls = nullptr) {
  return [calls](const float* points, std::int64_t n, float* sigma) {
    if (calls) ++*calls;
    for (std::int64_t i = 0; i < n; ++i) {
      sigma[i] = static_cast<float>(sphereDensity(Eigen::Vector3d(points[3 * i], points[3 * i + 1], points[3 * i + 2])));
    }
  };
}

DensityGrid sphereGrid(int n) {
  DensityGrid grid;
  grid.dims = Eigen::Vector3i::Constant(n);
  grid.spacing = Eigen::Vector3d::Constant(2.0 / (n - 1));
  grid.origin = Eigen::Vector3d::Constant(-1.0);
  grid.values.resize(static_cast<std::size_t>(n) * n * n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) grid.values[grid.index(i, j, k)] = static_cast<float>(sphereDensity(grid.node(i, j, k)));
  return grid;
}

std::vector<Eigen::Vector3d> randomPoints(std::size_t count, double half, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-half, half);
  std::vector<Eigen::Vector3d> points(count);
  for (auto& p : points) p = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return points;
}

TEST(DensityInside, TrilinearIsExactOnLinearFieldsAndZeroOutside) {
  DensityGrid grid;
  grid.dims = Eigen::Vector3i(3, 4, 5);
  grid.origin = Eigen::Vector3d(-1, 0, 2);
  grid.spacing = Eigen::Vector3d(0.5, 0.25, 1.0);
  grid.values.resize(60);
  auto linear = [](const Eigen::Vector3d& p) { return 1.0 + 2.0 * p.x() - 3.0 * p.y() + 0.5 * p.z(); };
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 3; ++i) grid.values[grid.index(i, j, k)] = static_cast<float>(linear(grid.node(i, j, k)));
  for (const Eigen::Vector3d p : {Eigen::Vector3d(-0.8, 0.1, 2.3), Eigen::Vector3d(-0.01, 0.74, 5.9),
                                  Eigen::Vector3d(0.0, 0.75, 6.0), Eigen::Vector3d(-1.0, 0.0, 2.0)}) {
    EXPECT_NEAR(sampleTrilinear(grid, p), linear(p), 1e-5) << p.transpose();
  }
  // Beyond one cell outside the nodes: empty space, as extractIsoSurface assumes.
  EXPECT_EQ(sampleTrilinear(grid, Eigen::Vector3d(5, 0.5, 3)), 0.0);
  EXPECT_EQ(sampleTrilinear(grid, Eigen::Vector3d(0, 0.5, 1e30)), 0.0);
  // Half a cell past the last node: halfway between the border value and 0.
  EXPECT_NEAR(sampleTrilinear(grid, Eigen::Vector3d(0.25, 0.0, 2.0)), 0.5 * grid.at(2, 0, 0), 1e-6);
}

TEST(DensityInside, FunctionAndGridAgreeWithTheSphere) {
  const DensityInsideTest direct(sphereFunction());
  const DensityInsideTest gridded(sphereGrid(41));
  const auto points = randomPoints(4000, 1.0, 7);
  const auto a = direct.inside(points);
  const auto b = gridded.inside(points);
  int checked = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double r = points[i].norm();
    if (std::abs(r - kRadius) < 0.01) continue;  // trilinear bends the sphere within a cell
    EXPECT_EQ(a[i] != 0, r < kRadius) << points[i].transpose();
    EXPECT_EQ(b[i] != 0, r < kRadius) << points[i].transpose();
    ++checked;
  }
  EXPECT_GT(checked, 3800);
  EXPECT_TRUE(direct.inside(Eigen::Vector3d(0.1, -0.2, 0.3)));
  EXPECT_FALSE(gridded.inside(Eigen::Vector3d(0.7, 0.0, 0.0)));
}

TEST(DensityInside, AgreesWithTheMeshExtractedAtTheSameThreshold) {
  const DensityGrid grid = sphereGrid(33);
  for (const SurfaceDefinition surface : {SurfaceDefinition::kDensity, SurfaceDefinition::kOpacity}) {
    MeshExtractionConfig extraction;
    extraction.surface = surface;
    const MeshExtractionResult extracted = extractMesh(grid, extraction);
    const InsideTest by_mesh(extracted.mesh);
    const DensityInsideTest by_density = DensityInsideTest::matchingExtraction(grid, extraction);
    const auto points = randomPoints(3000, 1.0, 11);
    const auto by_grid = by_density.inside(points);
    const double cell = grid.spacing.x();
    int compared = 0, inside = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      // Trilinear and the tetrahedral interpolant differ only within a cell of the surface.
      if (by_mesh.squaredDistance(points[i]) < 0.25 * cell * cell) continue;
      EXPECT_EQ(by_grid[i] != 0, by_mesh.inside(points[i])) << points[i].transpose();
      ++compared;
      inside += by_grid[i];
    }
    EXPECT_GT(compared, 2500);
    EXPECT_GT(inside, 100);  // r < 0.6 in [-1, 1]^3 is ~11 % of the points (less for opacity: inset)
  }
}

TEST(DensityInside, SmoothingIgnoresASpikeAndBatchesQueries) {
  // A floater: one 2 mm speck of very high density outside the sphere, as a NeRF leaves.
  const Eigen::Vector3d speck(0.8, 0.0, 0.0);
  int calls = 0;
  DensityFunction noisy = [&calls, speck](const float* points, std::int64_t n, float* sigma) {
    ++calls;
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
      sigma[i] = static_cast<float>(sphereDensity(p) + ((p - speck).norm() < 0.002 ? 8.0 : 0.0));
    }
  };
  const DensityInsideTest raw(noisy);
  EXPECT_TRUE(raw.inside(speck));
  DensityInsideConfig smoothing;
  smoothing.smoothing_radius = 0.01;
  const DensityInsideTest smoothed(noisy, smoothing);
  calls = 0;
  const std::vector<Eigen::Vector3d> points = {speck, Eigen::Vector3d(0.3, 0.1, 0.0), Eigen::Vector3d(0.0, 0.0, 0.9)};
  const auto inside = smoothed.inside(points);
  EXPECT_EQ(calls, 1);  // all stencil points go to the field in one batch
  EXPECT_EQ(inside[0], 0);
  EXPECT_EQ(inside[1], 1);
  EXPECT_EQ(inside[2], 0);
  // The stencil keeps a linear ramp's value: the surface does not move.
  EXPECT_NEAR(smoothed.density({Eigen::Vector3d(0.3, 0.0, 0.0)})[0], sphereDensity(Eigen::Vector3d(0.3, 0.0, 0.0)), 0.2);
}

TEST(DensityInside, BadInputIsRefusedWithTheValue) {
  DensityInsideConfig config;
  config.threshold = std::nan("");
  try {
    DensityInsideTest test(sphereFunction(), config);
    FAIL() << "NaN threshold accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("threshold nan"), std::string::npos) << e.what();
  }
  config = {};
  config.smoothing_radius = -0.1;
  try {
    DensityInsideTest test(sphereFunction(), config);
    FAIL() << "negative radius accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("-0.1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(DensityInsideTest(DensityFunction{}), core::Error);
  DensityGrid broken = sphereGrid(5);
  broken.values.pop_back();
  EXPECT_THROW(DensityInsideTest(std::move(broken)), core::Error);
}

}  // namespace
}  // namespace demnerf::geometry
