// The default DEM on the particle clouds the product itself makes, against the FEM baseline: the
// T-bar's exact surface sampled by each of `demnerf sample`'s samplers at a coarse spacing, and the
// 99-particle lattice bar of the node tests. Each solve must converge and agree with the FEM; a
// cloud the solver cannot handle must fail, never succeed with a positive energy under dead loads.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <iostream>
#include <string>
#include <type_traits>
#include <utility>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/mesh_distance.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/compare_results.hpp"
#include "demnerf/mechanics/mesh_size.hpp"
#include "demnerf/mechanics/particle_surface.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "demnerf/render/scene_geometry.hpp"
#include "../packages/mechanics/test/box_region.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

using demnerf::mechanics::test::box;

// config/scenarios/tbar_twist.yaml at half its torque (one load step for the FEM), in code so the
// test does not depend on the working directory.
core::Scenario tbarTwist() {
  core::Scenario s;
  s.name = "tbar_twist";
  s.material.youngs_modulus = 5e5;
  s.material.poisson_ratio = 0.4;
  core::Fixture base;
  base.name = "base";
  base.region = box(Vector3d(0, 0, 0), Vector3d(0.08, 0.08, 0.01));
  s.fixtures.push_back(base);
  core::Load front, back;
  front.name = "front_right";
  front.region = box(Vector3d(0.125, -0.03, 0.27), Vector3d(0.05, 0.01, 0.07));
  front.force = Vector3d(0, 1.0, 0);
  back.name = "back_left";
  back.region = box(Vector3d(-0.125, 0.03, 0.27), Vector3d(0.05, 0.01, 0.07));
  back.force = Vector3d(0, -1.0, 0);
  s.loads = {front, back};
  return s;
}

// `demnerf sample --method random --spacing S` on the exact T-bar.
core::ParticleCloud randomTBarCloud(double spacing) {
  demnerf::geometry::SamplerConfig sampler;
  sampler.method = demnerf::geometry::SamplingMethod::kRandom;
  sampler.spacing = spacing;
  return demnerf::geometry::sampleParticles(demnerf::render::makeSceneObject(demnerf::render::SceneKind::kTBar).mesh,
                                            sampler);
}

dm::SimulateOptions defaultOptions() {
  dm::SimulateOptions options;  // the product's default DEM
  options.control.time_limit = 120.0;
  return options;
}

// The lattice bar of test/check_helpers.hpp: (n + 1) x (m + 1)^2 particles over 0.1 x 0.02 x
// 0.02 m, every one with a cell of volume, the outer layer with area and a normal.
core::ParticleCloud latticeBar(double h) {
  const int n = static_cast<int>(std::lround(0.1 / h)), m = static_cast<int>(std::lround(0.02 / h));
  core::ParticleCloud cloud;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= m; ++j)
      for (int k = 0; k <= m; ++k) {
        Vector3d normal((i == n) - (i == 0), (j == m) - (j == 0), (k == m) - (k == 0));
        const bool surface = !normal.isZero();
        cloud.positions.emplace_back(i * h, -0.01 + j * h, -0.01 + k * h);
        cloud.volumes.push_back(h * h * h);
        cloud.normals.push_back(surface ? Vector3d(normal.normalized()) : normal);
        cloud.areas.push_back(surface ? h * h : 0.0);
        cloud.colors.push_back({200, 200, 200});
      }
  return cloud;
}

// The cuboid of the node tests (E 100 kPa) held by `clamp` and pushed on `load`; each test sets
// the load's force.
core::Scenario cuboidCantilever(const std::string& name, const core::Region& clamp, const core::Region& load) {
  core::Scenario scenario;
  scenario.name = name;
  scenario.material.youngs_modulus = 1e5;
  scenario.material.poisson_ratio = 0.3;
  core::Fixture fixture;
  fixture.name = "clamp";
  fixture.region = clamp;
  scenario.fixtures = {fixture};
  core::Load push;
  push.name = "push";
  push.region = load;
  scenario.loads = {push};
  return scenario;
}

core::Region halfspace(double x, double normal_x) {
  core::Region region;
  region.type = core::Region::Type::kHalfspace;
  region.center = Vector3d(x, 0, 0);
  region.normal = Vector3d(normal_x, 0, 0);
  return region;
}

}  // namespace

TEST(ProductClouds, SampledTBarConvergesToTheSameEnergyWhicheverSamplerMadeIt) {
  // The issue-13 failure: on `demnerf sample` particles the particle quadrature's energy could drop
  // without bound where the sampler leaves a gap under the surface (+7 J "converged"; later 38 %
  // apart between samplers). The default DEM integrates Gauss points in its cells and sizes them
  // from the body, so each sampler's cloud must give a checked equilibrium (negative energy under
  // these dead loads) and the three energies must agree (measured: within 12 %; the coarse Poisson
  // cloud, half the particles of the others, is the stiffest).
  const auto tbar = demnerf::render::makeSceneObject(demnerf::render::SceneKind::kTBar);
  const core::Scenario scenario = tbarTwist();
  std::vector<double> energies;
  for (const auto method : {demnerf::geometry::SamplingMethod::kGrid, demnerf::geometry::SamplingMethod::kRandom,
                            demnerf::geometry::SamplingMethod::kPoisson}) {
    SCOPED_TRACE(demnerf::geometry::samplingMethodName(method));
    demnerf::geometry::SamplerConfig sampler;
    sampler.method = method;
    sampler.spacing = 0.01;  // 1/6 of the section: the matrix's coarsest spacing
    const core::ParticleCloud cloud = demnerf::geometry::sampleParticles(tbar.mesh, sampler);
    dm::SimulateOptions options = defaultOptions();
    options.control.time_limit = 60.0;
    const dm::SimulationOutcome out = dm::simulate(cloud, scenario, dm::SolverChoice::kDem, options);
    std::cout << demnerf::geometry::samplingMethodName(method) << ": energy " << out.energy << " J, max |u| "
              << out.max_displacement << " m in " << out.seconds << " s\n";
    EXPECT_LT(out.energy, 0.0);
    EXPECT_GT(out.max_displacement, 0.0);
    energies.push_back(out.energy);
  }
  const auto [lowest, highest] = std::minmax_element(energies.begin(), energies.end());
  EXPECT_GT(*highest / *lowest, 0.8) << "the samplers' energies differ by more than 20 %";
}

TEST(ProductClouds, TheNodeTestsLatticeBarConvergesAndAgreesWithTheFem) {
  const core::ParticleCloud bar = latticeBar(0.01);
  ASSERT_EQ(bar.size(), 99u);
  core::Scenario s;
  s.name = "lattice_bar";
  s.material.youngs_modulus = 1e5;
  s.material.poisson_ratio = 0.3;
  core::Fixture clamp;
  clamp.name = "clamp";
  clamp.region = box(Vector3d::Zero(), Vector3d(0.01, 0.2, 0.2));
  s.fixtures.push_back(clamp);
  core::Load tip;  // dem_node's wrench at the tool frame (0.1, 0, 0), contact radius 15 mm
  tip.name = "tip";
  tip.region.type = core::Region::Type::kSphere;
  tip.region.center = Vector3d(0.1, 0, 0);
  tip.region.radius = 0.015;
  tip.force = Vector3d(0, 0, -0.02);
  s.loads.push_back(tip);
  dm::SimulateOptions fem = defaultOptions();
  fem.voxel.order = 2;
  const dm::SimulationOutcome reference = dm::simulate(bar, s, dm::SolverChoice::kFem, fem);
  const dm::SimulationOutcome dem = dm::simulate(bar, s, dm::SolverChoice::kDem, defaultOptions());
  const dm::ResultComparison c = dm::compareResults(dem.field, reference.field);
  // Measured 10.7 % (tip 4.6 % apart): three particles across the section, a coarse body for both
  // (a 20 mm grid against TET10 voxels of 10 mm).
  EXPECT_LT(c.rel_l2, 0.15);
  EXPECT_LT(dem.energy, 0.0);
}

TEST(ProductClouds, ACloudTheSolverCannotHandleFailsAndNeverReturnsAPositiveEnergy) {
  // Sparse random particles and 40 times the twist: far more than the soft material takes. Either
  // an error, or an answer that is a minimum (energy <= 0 under dead loads); never a "success"
  // above 0 J.
  const core::ParticleCloud sparse = randomTBarCloud(0.02);
  core::Scenario heavy = tbarTwist();
  for (auto& load : heavy.loads) load.force *= 40.0;  // far beyond what the material takes
  dm::SimulateOptions options = defaultOptions();
  options.control.time_limit = 20.0;
  try {
    const dm::SimulationOutcome out = dm::simulate(sparse, heavy, dm::SolverChoice::kDem, options);
    EXPECT_LE(out.energy, 0.0) << "a success must be a minimum";
  } catch (const dm::SolveError& e) {
    EXPECT_FALSE(std::string(e.what()).empty());
  }
}

TEST(ProductClouds, TheFemFinishesAGentlePushOnACoarseSampledCuboid) {
  // The dem_node_render rostest's first solve (0.01 N down on the cuboid's free end) failed one run
  // in three: on a coarse Poisson cloud the FEM's voxel mesh is a single TET10 hex, near the answer
  // the energy's changes fell below its own round-off, no backtracked step showed a decrease, and
  // Newton stalled at a residual of 1e-5 of the load ("did not converge"). Each seed's cloud must
  // now converge, and the gentle pushes stay in the linear range: ten times the push, ten times the
  // displacement.
  // As `demnerf synth`, `sample` and `simulate` hand them on: the mesh and the cloud through PLY.
  const auto throughPly = [](const auto& data) {
    const std::string path = ::testing::TempDir() + "gentle_push.ply";
    if constexpr (std::is_same_v<std::decay_t<decltype(data)>, core::TriangleMesh>) {
      core::writeMesh(path, data);
      return core::readMesh(path);
    } else {
      core::writeParticles(path, data);
      return core::readParticles(path);
    }
  };
  const core::TriangleMesh mesh = throughPly(demnerf::render::makeSceneObject(demnerf::render::SceneKind::kCuboid).mesh);
  // Clamped over x <= 0.015 m, pushed on x >= 0.105 m.
  core::Scenario scenario = cuboidCantilever("gentle_push", box(Vector3d(0, 0, 0), Vector3d(0.03, 1, 1)),
                                              box(Vector3d(0.125, 0, 0), Vector3d(0.04, 1, 1)));
  for (const auto& [spacing, seed] : {std::pair<double, std::uint64_t>{0.03, 1}, {0.03, 2}, {0.02, 1}, {0.02, 2}}) {
    SCOPED_TRACE("spacing " + std::to_string(spacing) + " m, seed " + std::to_string(seed));
    demnerf::geometry::SamplerConfig sampler;
    sampler.method = demnerf::geometry::SamplingMethod::kPoisson;
    sampler.spacing = spacing;
    sampler.seed = seed;
    const core::ParticleCloud cloud = throughPly(demnerf::geometry::sampleParticles(mesh, sampler));
    std::vector<double> reach;
    for (const double force : {1e-4, 1e-3, 1e-2}) {
      scenario.loads[0].force = Vector3d(0, 0, -force);
      dm::SimulationOutcome out;
      ASSERT_NO_THROW(out = dm::simulate(cloud, scenario, dm::SolverChoice::kFem, defaultOptions())) << force << " N";
      EXPECT_LT(out.energy, 0.0) << force << " N";
      reach.push_back(out.max_displacement);
    }
    EXPECT_NEAR(reach[1] / reach[0], 10.0, 0.01);
    EXPECT_NEAR(reach[2] / reach[1], 10.0, 0.01);
  }
}

TEST(ProductClouds, TheDemConvergesOnAPoissonCuboidWithAHalfspaceClamp) {
  // A halfspace clamp holds its whole volume (no held face): D = 0 there, so Gauss points inside
  // it do not see the field. The Poisson cloud's grid cell [0, 20] mm straddles the clamp's plane
  // x = 15 mm with both its Gauss points per axis inside the clamp, which left the strip 15-24 mm
  // without a quadrature point: the field inverted there at a particle ("did not converge at load
  // fraction 0.875 even after 4 load-step halvings" at 20 N; 1.9 times the FEM's energy at
  // 1e-4 N). The cells the clamp's plane cuts are now split. The DEM must agree with the DEM on a
  // grid cloud of the same body (sampler independence: 0.3 % measured) and with the FEM. The FEM
  // meshes the surface the particles describe with CGAL, so its answer hardly depends on the
  // cloud (before, voxel blocks of two spacings placed by the bounding box spread its answers over
  // 0.019-0.055 m in max |u| on clouds of this one body; docs/dem_feature_grid.md, "The FEM on a
  // cloud without its surface").
  const core::TriangleMesh mesh = demnerf::render::makeSceneObject(demnerf::render::SceneKind::kCuboid).mesh;
  core::Scenario scenario = cuboidCantilever("halfspace_clamp", halfspace(0.015, 1.0), halfspace(0.105, -1.0));
  const auto sample = [&mesh](demnerf::geometry::SamplingMethod method) {
    demnerf::geometry::SamplerConfig sampler;
    sampler.method = method;
    sampler.spacing = 0.02;
    sampler.seed = 1;
    return demnerf::geometry::sampleParticles(mesh, sampler);
  };
  const core::ParticleCloud cloud = sample(demnerf::geometry::SamplingMethod::kPoisson);
  dm::SimulationOutcome dem, fem;
  for (const double force : {1e-4, 20.0}) {
    SCOPED_TRACE(std::to_string(force) + " N");
    scenario.loads[0].force = Vector3d(0, 0, -force);
    ASSERT_NO_THROW(dem = dm::simulate(cloud, scenario, dm::SolverChoice::kDem, defaultOptions()));
    ASSERT_NO_THROW(fem = dm::simulate(cloud, scenario, dm::SolverChoice::kFem, defaultOptions()));
    EXPECT_NEAR(dem.max_displacement / fem.max_displacement, 1.0, 0.1);
    EXPECT_NEAR(dem.energy / fem.energy, 1.0, 0.1);
  }
  dm::SimulationOutcome grid_dem, grid_fem;
  const core::ParticleCloud grid = sample(demnerf::geometry::SamplingMethod::kGrid);
  ASSERT_NO_THROW(grid_dem = dm::simulate(grid, scenario, dm::SolverChoice::kDem, defaultOptions()));
  EXPECT_NEAR(dem.max_displacement / grid_dem.max_displacement, 1.0, 0.03);
  EXPECT_NEAR(dem.energy / grid_dem.energy, 1.0, 0.03);
  ASSERT_NO_THROW(grid_fem = dm::simulate(grid, scenario, dm::SolverChoice::kFem, defaultOptions()));
  EXPECT_NEAR(fem.energy / grid_fem.energy, 1.0, 0.02);
  EXPECT_NEAR(fem.max_displacement / grid_fem.max_displacement, 1.0, 0.03);
}

namespace {

// The vertices of a polyhedral mesh that lie on its edges: two of their faces meet at more than
// 60 degrees.
std::vector<Vector3d> edgeVertices(const core::TriangleMesh& mesh) {
  std::vector<std::vector<Vector3d>> normals(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    const Vector3d n =
        (mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]).normalized();
    for (int k = 0; k < 3; ++k) normals[f[k]].push_back(n);
  }
  std::vector<Vector3d> on_edges;
  for (std::size_t v = 0; v < normals.size(); ++v) {
    bool edge = false;
    for (const Vector3d& a : normals[v])
      for (const Vector3d& b : normals[v]) edge = edge || a.dot(b) < 0.5;
    if (edge) on_edges.push_back(mesh.vertices[v]);
  }
  return on_edges;
}

double shareWithin(const std::vector<double>& distances, double limit) {
  return static_cast<double>(std::count_if(distances.begin(), distances.end(), [&](double d) { return d <= limit; })) /
         static_cast<double>(distances.size());
}

}  // namespace

TEST(ProductClouds, TheSurfaceOfASampledTBarKeepsItsEdges) {
  // The FEM meshes the surface a cloud's particles describe when it has no other. Extracted from
  // their tangent planes every step, it is exact on the faces but cut straight across the edges
  // between them; sharpenEdges() puts the edges back where the planes meet, the convex ones of the
  // flange and the re-entrant ones under the crossbar alike, and keeps the surface closed. (Corners,
  // where three faces meet, keep a cut about a fifth of a step deep.)
  const auto tbar = demnerf::render::makeSceneObject(demnerf::render::SceneKind::kTBar);
  const core::ParticleCloud cloud = randomTBarCloud(0.01);
  const double step = 0.003;
  const core::TriangleMesh sharp = dm::surfaceOfParticles(cloud, step);
  const core::TriangleMesh chamfered = dm::surfaceOfParticles(cloud, step, false);
  // The mesher takes it: closed, consistently oriented, each edge between two triangles.
  dm::CgalMeshConfig coarse;
  coarse.cell = 0.03;
  coarse.order = 1;
  coarse.protect_creases = false;
  EXPECT_GT(dm::cgalMeshFromSurface(sharp, coarse).elements.size(), 0u);
  const std::vector<Vector3d> edges = edgeVertices(tbar.mesh);
  ASSERT_GT(edges.size(), 100u);
  const double on_edge = 0.02 * step;
  const double sharp_share = shareWithin(demnerf::geometry::distancesToMesh(sharp, edges), on_edge);
  const double chamfered_share = shareWithin(demnerf::geometry::distancesToMesh(chamfered, edges), on_edge);
  const dm::BodyMeasures exact = dm::measureSurface(tbar.mesh), a = dm::measureSurface(sharp),
                         b = dm::measureSurface(chamfered);
  std::cout << "the T-bar's edge points on the surface (within " << on_edge * 1e3 << " mm): sharpened "
            << sharp_share * 100 << " %, chamfered " << chamfered_share * 100 << " %; volume "
            << a.volume / exact.volume - 1 << " / " << b.volume / exact.volume - 1 << " from the T-bar's\n";
  EXPECT_GT(sharp_share, 0.95);
  EXPECT_LT(chamfered_share, 0.75);  // measured 50 %: edges the samples straddle evenly are exact
  EXPECT_NEAR(a.volume / exact.volume, 1.0, 0.002);
}
