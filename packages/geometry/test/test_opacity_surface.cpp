#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/mesh_distance.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/mesh_simplification.hpp"
#include "demnerf/geometry/optical_depth.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

// What a NeRF learns for an opaque box: a thin shell of high density at the surface, and
// inside whatever it likes - here low density with a hollow, which a density threshold turns
// into a cavity (or worse), while the surface as rendered is the box.
constexpr double kHalf[3] = {0.3, 0.2, 0.1};
double nerfLikeBox(const float* p) {
  double outside = 0.0;  // distance outside the box (0 inside)
  double depth = 1e9;    // distance inside from the nearest face
  for (int a = 0; a < 3; ++a) {
    const double d = std::abs(p[a]) - kHalf[a];
    outside = std::max(outside, d);
    depth = std::min(depth, -d);
  }
  if (outside > 0) return 0.0;
  return depth < 0.02 ? 500.0 : 1.0;  // 2 cm shell, almost empty inside
}

DensityFunction boxFunction() {
  return [](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) sigma[i] = static_cast<float>(nerfLikeBox(points + 3 * i));
  };
}

const Eigen::AlignedBox3d kSceneBox(Eigen::Vector3d(-0.4, -0.3, -0.2), Eigen::Vector3d(0.4, 0.3, 0.2));

TEST(DensitySampling, CubicCellsCentredOnTheBox) {
  int calls = 0;
  DensityFunction f = [&calls](const float* p, std::int64_t n, float* s) {
    ++calls;
    for (std::int64_t i = 0; i < n; ++i) s[i] = p[3 * i] + 2 * p[3 * i + 1] + 3 * p[3 * i + 2];
  };
  const DensityGrid grid = sampleDensityGrid(f, kSceneBox, 40);
  EXPECT_EQ(grid.dims, Eigen::Vector3i(40, 30, 20));
  EXPECT_NEAR(grid.spacing.x(), 0.02, 1e-12);
  EXPECT_EQ(grid.spacing, Eigen::Vector3d::Constant(grid.spacing.x()));
  EXPECT_EQ(calls, 20);  // one batch per z slice
  EXPECT_TRUE(grid.node(0, 0, 0).isApprox(Eigen::Vector3d(-0.39, -0.29, -0.19)));
  const Eigen::Vector3d last = grid.node(39, 29, 19);
  EXPECT_NEAR(grid.at(39, 29, 19), last.x() + 2 * last.y() + 3 * last.z(), 1e-5);
  EXPECT_THROW(sampleDensityGrid(f, kSceneBox, 1), core::Error);
  EXPECT_THROW(sampleDensityGrid(f, Eigen::AlignedBox3d(), 16), core::Error);
  EXPECT_THROW(sampleDensityGrid(DensityFunction{}, kSceneBox, 16), core::Error);
}

TEST(OpticalDepth, MatchesTheIntegralAlongTheClearestAxis) {
  DensityGrid grid;
  grid.dims = Eigen::Vector3i(7, 3, 3);
  grid.spacing = Eigen::Vector3d(0.1, 1.0, 1.0);  // y and z lines are long, x lines short
  grid.values.assign(63, 2.0f);
  const DensityGrid tau = axisOpticalDepth(grid);
  // Node i along x: trapezoid from sigma 0 outside: 0.5*2*0.1 + 2*0.1*i from the near end.
  for (int i = 0; i < 7; ++i) {
    const int from_end = std::min(i, 6 - i);
    // y and z lines: at best 1.0 (border node, one half step of 1.0) - larger than x beyond i = 4.
    const double expected = std::min(0.1 + 0.2 * from_end, 1.0);
    EXPECT_NEAR(tau.at(i, 1, 1), expected, 1e-6) << i;
  }
  EXPECT_NEAR(tau.at(3, 0, 0), 0.7, 1e-6);  // x: 0.1 + 0.6 beats y: 1.0
}

TEST(OpacitySurface, FindsTheRenderedBoxWhateverTheDensityScale) {
  const DensityGrid grid = sampleDensityGrid(boxFunction(), kSceneBox, 80);  // 1 cm cells
  const double h = grid.spacing.x();
  // The box faces lie halfway between nodes and the density jumps there, so any iso-surface
  // may sit anywhere in that half cell: the volume is bounded by the box grown or shrunk by h/2.
  auto boxVolume = [](double offset) {
    return 8 * (kHalf[0] + offset) * (kHalf[1] + offset) * (kHalf[2] + offset);
  };
  MeshExtractionConfig opacity;
  opacity.surface = SurfaceDefinition::kOpacity;
  const MeshExtractionResult by_opacity = extractMesh(grid, opacity);
  EXPECT_TRUE(by_opacity.closed);
  EXPECT_NEAR(by_opacity.iso_value, std::log(2.0), 1e-12);
  EXPECT_GT(by_opacity.volume, boxVolume(-0.5 * h));
  EXPECT_LT(by_opacity.volume, boxVolume(0.5 * h));
  const MeshDistance d = meshDistance(by_opacity.mesh, testing::makeBox(-Eigen::Vector3d(kHalf), Eigen::Vector3d(kHalf)));
  EXPECT_LT(d.chamfer, 0.5 * h);
  // The nearly empty interior (density 1, a cavity for any threshold above 1) is filled: the
  // opacity surface is one sheet; a density threshold of 100 gives two (outer and cavity).
  MeshRepairConfig keep_all;
  keep_all.keep_largest_component = false;
  opacity.repair = keep_all;
  EXPECT_NEAR(extractMesh(grid, opacity).volume, by_opacity.volume, 1e-12);
  MeshExtractionConfig high;
  high.threshold = 100;
  high.repair = keep_all;
  EXPECT_LT(extractMesh(grid, high).volume, 0.7 * by_opacity.volume);  // the cavity is subtracted
  // Scaling the density by 100 keeps the opacity surface within the same half cell.
  DensityGrid scaled = grid;
  for (float& v : scaled.values) v *= 100.0f;
  const double scaled_volume = extractMesh(scaled, opacity).volume;
  EXPECT_GT(scaled_volume, boxVolume(-0.5 * h));
  EXPECT_LT(scaled_volume, boxVolume(0.5 * h));
}

TEST(OpacitySurface, BadOpacityAndTransparentFieldsAreReported) {
  DensityGrid grid = sampleDensityGrid(boxFunction(), kSceneBox, 20);
  MeshExtractionConfig config;
  config.surface = SurfaceDefinition::kOpacity;
  config.opacity = 1.0;
  try {
    extractMesh(grid, config);
    FAIL() << "opacity 1 accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("opacity 1 must be in (0, 1)"), std::string::npos) << e.what();
  }
  config.opacity = 0.5;
  for (float& v : grid.values) v = 1e-3f;  // an untrained, nearly transparent field
  try {
    extractMesh(grid, config);
    FAIL() << "transparent field gave a surface";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no surface at opacity 0.5"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parseSurfaceDefinition("opacity"), SurfaceDefinition::kOpacity);
  EXPECT_THROW(parseSurfaceDefinition("alpha"), core::Error);
}

TEST(MeshSimplification, KeepsTheSphereClosedWithinTheBudget) {
  const auto sphere = testing::makeIcosphere(1.0, 5);  // 20480 faces
  MeshSimplificationReport report;
  MeshSimplificationConfig config;
  config.max_faces = 2000;
  const auto simple = simplifyMesh(sphere, config, &report);
  EXPECT_EQ(report.faces_before, sphere.faces.size());
  EXPECT_LE(simple.faces.size(), 2000u);
  EXPECT_GT(simple.faces.size(), 1500u);
  EXPECT_EQ(report.faces_after, simple.faces.size());
  const MeshSummary before = analyzeMesh(sphere), after = analyzeMesh(simple);
  EXPECT_TRUE(after.closed());
  EXPECT_NEAR(after.volume() / before.volume(), 1.0, 0.01);  // Lindstrom-Turk keeps the volume
  MeshDistanceConfig samples;
  samples.samples = 3000;
  EXPECT_LT(meshDistance(simple, sphere, samples).hausdorff, 0.02);
  // Within budget: untouched.
  config.max_faces = 100000;
  EXPECT_EQ(simplifyMesh(sphere, config).faces.size(), sphere.faces.size());
}

}  // namespace
}  // namespace demnerf::geometry
