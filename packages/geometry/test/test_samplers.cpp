#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/geometry/winding_number.hpp"
#include "test_meshes.hpp"

namespace demnerf::geometry {
namespace {

using testing::makeBox;
using testing::makeIcosphere;

SamplerConfig configFor(SamplingMethod method, double spacing) {
  SamplerConfig config;
  config.method = method;
  config.spacing = spacing;
  config.seed = 7;
  return config;
}

struct Sums {
  double volume = 0, area = 0, second_moment_x = 0;
  Eigen::Vector3d area_normal = Eigen::Vector3d::Zero();  // sum A n: zero for a closed surface
  double flux = 0;  // sum A n.x = 3 V (divergence theorem)
  std::size_t interior = 0, surface = 0;
};

Sums sums(const core::ParticleCloud& cloud, bool surface_volumes = false) {
  Sums s;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    s.volume += cloud.volumes[i];
    s.second_moment_x += cloud.volumes[i] * cloud.positions[i].x() * cloud.positions[i].x();
    if (cloud.isSurface(i)) {
      ++s.surface;
      s.area += cloud.areas[i];
      s.area_normal += cloud.areas[i] * cloud.normals[i];
      s.flux += cloud.areas[i] * cloud.normals[i].dot(cloud.positions[i]);
      if (!surface_volumes) EXPECT_EQ(cloud.volumes[i], 0.0);
      EXPECT_NEAR(cloud.normals[i].norm(), 1.0, 1e-9);
    } else {
      ++s.interior;
      EXPECT_GT(cloud.volumes[i], 0.0);
    }
  }
  return s;
}

const SamplingMethod kMethods[] = {SamplingMethod::kRandom, SamplingMethod::kPoisson, SamplingMethod::kGrid};

TEST(GridSampler, UnitCubeCountsAndWeightsAreExact) {
  const auto cube = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  SamplingReport report;
  const auto cloud = sampleParticles(cube, configFor(SamplingMethod::kGrid, 0.1), &report);
  EXPECT_EQ(report.interior, 1000u);  // 10^3 cell centres
  EXPECT_EQ(report.surface, 600u);    // 10^2 line crossings on each of 6 faces
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.isSurface(i)) {
      EXPECT_NEAR(cloud.areas[i], 0.01, 1e-12);
      // Each sits on a face, with that face's normal.
      const Eigen::Vector3d p = cloud.positions[i];
      const Eigen::Vector3d n = cloud.normals[i];
      int axis = 0;
      n.cwiseAbs().maxCoeff(&axis);
      EXPECT_NEAR(p[axis], n[axis] > 0 ? 1.0 : 0.0, 1e-12);
    } else {
      EXPECT_NEAR(cloud.volumes[i], 1e-3, 1e-12);
    }
  }
}

// A mesh read from a PLY file carries float coordinates: 0.3 m is stored as 0.30000001 m, a
// hair over 50 spacings of 6 mm. The lattice must still be the body's 50 cell centres per metre
// of 0.3, not 51 nodes with a layer on each face.
TEST(GridSampler, ABoxStoredInFloatsKeepsItsCellCentres) {
  const Eigen::Vector3d hi(static_cast<float>(0.3), static_cast<float>(0.06), static_cast<float>(0.06));
  ASSERT_GT(hi.x() / 0.006, 50.0 + 1e-6);  // the rounding the sampler must absorb
  const auto bar = makeBox(Eigen::Vector3d::Zero(), hi);
  SamplingReport report;
  const auto cloud = sampleParticles(bar, configFor(SamplingMethod::kGrid, 0.006), &report);
  EXPECT_EQ(report.interior, 50u * 10u * 10u);
  double nearest_face = 1.0;  // over the interior particles: half a spacing at cell centres
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.positions[i];
    if (!cloud.isSurface(i)) nearest_face = std::min(nearest_face, p.cwiseMin(hi - p).minCoeff());
  }
  EXPECT_NEAR(nearest_face, 0.003, 1e-6);
}

TEST(GridSampler, BoxOffTheGridGetsClippedCellVolumes) {
  // Unit cube at h = 0.3: four nodes per axis at 0.05, 0.35, 0.65, 0.95, whose cells clipped
  // to the cube are 0.2, 0.3, 0.3, 0.2 long.
  const auto cube = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  const auto cloud = sampleParticles(cube, configFor(SamplingMethod::kGrid, 0.3));
  auto clipped = [](double x) { return (x < 0.2 || x > 0.8) ? 0.2 : 0.3; };
  std::size_t interior = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.isSurface(i)) continue;
    ++interior;
    const Eigen::Vector3d& p = cloud.positions[i];
    EXPECT_NEAR(cloud.volumes[i], clipped(p.x()) * clipped(p.y()) * clipped(p.z()), 1e-9) << p.transpose();
  }
  EXPECT_EQ(interior, 64u);
  const auto box = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 1.0, 0.5));
  SamplingReport report;
  sampleParticles(box, configFor(SamplingMethod::kGrid, 0.1), &report);
  EXPECT_EQ(report.interior, 20u * 10u * 5u);
  EXPECT_EQ(report.surface, 2u * (20 * 10 + 20 * 5 + 10 * 5));
}

TEST(Samplers, CubeAndSphereSumsMatchTheAnalyticValues) {
  const auto cube = makeBox(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
  const auto sphere = makeIcosphere(1.0, 5);
  const double sphere_volume = 4.0 / 3.0 * M_PI, sphere_area = 4.0 * M_PI;
  ASSERT_NEAR(testing::polyhedronVolume(sphere) / sphere_volume, 1.0, 0.002);  // mesh ~ sphere
  for (SamplingMethod method : kMethods) {
    SCOPED_TRACE(samplingMethodName(method));
    // Poisson keeps interior particles r from the surface: let surface particles carry volume
    // for the moment check (the default's inward lean is checked below).
    SamplerConfig cube_config = configFor(method, 0.08);
    cube_config.surface_volumes = method == SamplingMethod::kPoisson;
    const Sums c = sums(sampleParticles(cube, cube_config), cube_config.surface_volumes);
    EXPECT_NEAR(c.volume, 1.0, 0.01);
    EXPECT_NEAR(c.area, 6.0, 0.02 * 6.0);
    EXPECT_NEAR(c.flux, 3.0, 0.02 * 3.0);
    EXPECT_LT(c.area_normal.norm(), 0.02 * 6.0);
    EXPECT_NEAR(c.second_moment_x, 1.0 / 12.0, 0.05 / 12.0);  // int x^2 dV over the cube

    SamplerConfig sphere_config = configFor(method, 0.12);
    sphere_config.surface_volumes = cube_config.surface_volumes;
    const Sums s = sums(sampleParticles(sphere, sphere_config), sphere_config.surface_volumes);
    EXPECT_NEAR(s.volume / sphere_volume, 1.0, 0.01);
    EXPECT_NEAR(s.area / sphere_area, 1.0, 0.02);
    EXPECT_NEAR(s.flux / (3.0 * sphere_volume), 1.0, 0.02);
    EXPECT_LT(s.area_normal.norm(), 0.02 * sphere_area);
    EXPECT_NEAR(s.second_moment_x / (4.0 * M_PI / 15.0), 1.0, 0.05);  // int x^2 dV over the ball
  }
}

TEST(PoissonSampler, InteriorOnlyVolumesLeanInwardAsDocumented) {
  const auto cube = makeBox(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
  const Sums c = sums(sampleParticles(cube, configFor(SamplingMethod::kPoisson, 0.08)));
  EXPECT_NEAR(c.volume, 1.0, 0.01);
  EXPECT_LT(c.second_moment_x, 1.0 / 12.0);
  EXPECT_GT(c.second_moment_x, 0.85 / 12.0);
}

TEST(Samplers, ParticlesLieInsideAndOnTheSurface) {
  const auto sphere = makeIcosphere(1.0, 3, Eigen::Vector3d(0.3, -0.2, 0.1));
  for (SamplingMethod method : kMethods) {
    SCOPED_TRACE(samplingMethodName(method));
    const auto cloud = sampleParticles(sphere, configFor(method, 0.15));
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3d local = cloud.positions[i] - Eigen::Vector3d(0.3, -0.2, 0.1);
      if (cloud.isSurface(i)) {
        EXPECT_NEAR(local.norm(), 1.0, 0.02);  // on the polyhedron, close to the sphere
        EXPECT_GT(cloud.normals[i].dot(local.normalized()), 0.95);  // outward
      } else {
        EXPECT_GT(windingNumber(sphere, cloud.positions[i]), 0.5);
      }
    }
  }
}

TEST(PoissonSampler, EveryPairIsAtLeastRApart) {
  const auto sphere = makeIcosphere(1.0, 3);
  const double r = 0.15;
  const auto cloud = sampleParticles(sphere, configFor(SamplingMethod::kPoisson, r));
  double closest = 1e9;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (std::size_t j = i + 1; j < cloud.size(); ++j)
      closest = std::min(closest, (cloud.positions[i] - cloud.positions[j]).norm());
  EXPECT_GE(closest, r);
  EXPECT_LT(closest, 1.2 * r);  // and tightly packed
  // Nearly maximal: no spot inside the body is farther than 2r from every particle.
  EXPECT_GT(cloud.size(), 0.3 * (4.0 / 3.0 * M_PI) / (r * r * r));
}

TEST(Samplers, DeterministicForASeedAndColoured) {
  const auto sphere = makeIcosphere(1.0, 2);
  for (SamplingMethod method : kMethods) {
    SCOPED_TRACE(samplingMethodName(method));
    SamplerConfig config = configFor(method, 0.2);
    const auto a = sampleParticles(sphere, config);
    const auto b = sampleParticles(sphere, config);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a.positions[i], b.positions[i]);
    EXPECT_EQ(a.colors[0], (std::array<std::uint8_t, 3>{128, 128, 128}));
    config.seed = 8;
    config.color = [](const Eigen::Vector3d& p) { return Eigen::Vector3d(p.x() > 0 ? 1.0 : 0.0, 0.0, 2.0); };
    const auto c = sampleParticles(sphere, config);
    if (method != SamplingMethod::kGrid) EXPECT_NE(c.positions[0], a.positions[0]);
    for (std::size_t i = 0; i < c.size(); ++i) {
      EXPECT_EQ(c.colors[i][0], c.positions[i].x() > 0 ? 255 : 0);
      EXPECT_EQ(c.colors[i][2], 255);  // clamped
    }
  }
}

TEST(Samplers, UniformWeightsOption) {
  const auto sphere = makeIcosphere(1.0, 2);
  SamplerConfig config = configFor(SamplingMethod::kRandom, 0.2);
  config.volume_weights = VolumeWeights::kUniform;
  SamplingReport report;
  const auto cloud = sampleParticles(sphere, config, &report);
  EXPECT_NEAR(cloud.volumes[0], report.mesh_volume / report.interior, 1e-12);
  EXPECT_NEAR(report.volume_sum, report.mesh_volume, 1e-9);
  EXPECT_NEAR(report.area_sum, report.mesh_area, 1e-9);
}

TEST(Samplers, BadSpacingAndMeshesGiveClearErrors) {
  const auto cube = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  auto messageOf = [](const core::TriangleMesh& mesh, const SamplerConfig& config) -> std::string {
    try {
      sampleParticles(mesh, config);
    } catch (const core::Error& error) {
      return error.what();
    }
    return "";
  };
  for (SamplingMethod method : kMethods) {
    SCOPED_TRACE(samplingMethodName(method));
    const std::string large = messageOf(cube, configFor(method, 0.6));
    EXPECT_NE(large.find("too large"), std::string::npos) << large;
    EXPECT_NE(large.find("0.6"), std::string::npos) << large;
    EXPECT_NE(messageOf(cube, configFor(method, 0.0)).find("positive"), std::string::npos);
    EXPECT_NE(messageOf(cube, configFor(method, std::nan(""))).find("positive"), std::string::npos);
    EXPECT_NE(messageOf(cube, configFor(method, 1e-4)).find("too small"), std::string::npos);
  }
  // A plate thinner than r: its volume would hold many particles, but every interior
  // candidate is closer than r to the surface particles.
  const auto plate = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 10, 0.01));
  const std::string thin = messageOf(plate, configFor(SamplingMethod::kPoisson, 0.2));
  EXPECT_NE(thin.find("too large"), std::string::npos) << thin;

  auto open = cube;
  open.faces.pop_back();
  EXPECT_NE(messageOf(open, configFor(SamplingMethod::kPoisson, 0.1)).find("open"), std::string::npos);
  EXPECT_NE(messageOf(core::TriangleMesh{}, configFor(SamplingMethod::kPoisson, 0.1)).find("empty"), std::string::npos);
  auto degenerate = cube;
  degenerate.vertices[7] = degenerate.vertices[6];
  EXPECT_NE(messageOf(degenerate, configFor(SamplingMethod::kGrid, 0.1)).find("degenerate"), std::string::npos);
  EXPECT_THROW(parseSamplingMethod("hexagonal"), core::Error);
  EXPECT_EQ(parseSamplingMethod("grid"), SamplingMethod::kGrid);
}

TEST(Samplers, InwardFacingMeshGetsOutwardNormals) {
  const auto sphere = flippedFaces(makeIcosphere(1.0, 2));
  const auto cloud = sampleParticles(sphere, configFor(SamplingMethod::kPoisson, 0.2));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.isSurface(i)) EXPECT_GT(cloud.normals[i].dot(cloud.positions[i]), 0.0);
  }
}

}  // namespace
}  // namespace demnerf::geometry
