#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/compare_results.hpp"
#include "demnerf/mechanics/held_volume_planes.hpp"
#include "demnerf/mechanics/mesh_size.hpp"
#include "demnerf/mechanics/particle_surface.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

#include "box_region.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

using dm::boxSurface;

double meshVolume(const dm::TetMesh& mesh) {
  double total = 0;
  for (const auto& e : mesh.elements) {
    double v = 0;
    dm::barycentricGradients({mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]}, &v);
    total += v;
  }
  return total;
}

using demnerf::mechanics::test::box;

// Box [0,L]x[0,1]x[0,1] on rollers at x = 0, y = 0, z = 0, pulled by P11 on x = L.
core::Scenario uniaxial(double p11, double length) {
  core::Scenario s;
  s.name = "uniaxial";
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  for (int axis = 0; axis < 3; ++axis) {
    core::Fixture f;
    f.name = std::string("roller_") + "xyz"[axis];
    Vector3d c(0.5 * length, 0.5, 0.5), size(2 * length, 2, 2);
    c(axis) = 0.0;
    size(axis) = 1e-6;
    f.region = box(c, size);
    f.constrained = Eigen::Vector3i::Zero();
    f.constrained(axis) = 1;
    s.fixtures.push_back(f);
  }
  core::Load pull;
  pull.name = "pull";
  pull.region = box(Vector3d(length, 0.5, 0.5), Vector3d(1e-6, 2, 2));
  pull.force = Vector3d(p11, 0, 0);
  s.loads = {pull};
  return s;
}

TEST(VoxelMesh, BoxSurfaceGivesTheBoxExactly) {
  const core::TriangleMesh surface = boxSurface(Vector3d(-0.1, 0, 0.2), Vector3d(0.2, 0.06, 0.26));
  EXPECT_TRUE(dm::insideSurface(surface, Vector3d(0.0, 0.03, 0.23)));
  EXPECT_FALSE(dm::insideSurface(surface, Vector3d(0.3, 0.03, 0.23)));
  EXPECT_FALSE(dm::insideSurface(surface, Vector3d(0.0, 0.03, 0.27)));
  dm::VoxelMeshConfig config;
  config.cell = 0.02;
  config.order = 1;
  const dm::TetMesh mesh = dm::voxelMeshFromSurface(surface, config);
  EXPECT_NEAR(meshVolume(mesh), 0.3 * 0.06 * 0.06, 1e-12);
  EXPECT_EQ(mesh.elements.size(), 6u * 15 * 3 * 3);
  config.cell = 0.0;
  EXPECT_THROW(dm::voxelMeshFromSurface(surface, config), core::Error);
}

TEST(VoxelMesh, GridParticlesGiveTheirCells) {
  core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(0.4, 0.2, 0.2), Eigen::Vector3i(4, 2, 2));
  // Remove one interior cell's particle: its cell must disappear from the mesh.
  double volume = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) volume += cloud.volumes[i];
  cloud.volumes[0] = 0.0;
  const dm::TetMesh mesh = dm::voxelMeshFromParticles(cloud, {});
  EXPECT_EQ(mesh.order, 2);
  EXPECT_NEAR(meshVolume(mesh), volume - 0.001, 1e-12);
}

TEST(VoxelMesh, CoarseCellsOverGridParticlesKeepTheBody) {
  // 0.25 spacing, 0.5 cells: each hex is 2 x 2 x 2 particle cells, the box keeps its faces.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4));
  dm::VoxelMeshConfig config;
  config.order = 1;
  config.cell = 0.5;
  const dm::TetMesh mesh = dm::voxelMeshFromParticles(cloud, config);
  double volume = 0;
  Eigen::Vector3d lo = mesh.nodes[0], hi = lo;
  for (const auto& e : mesh.elements) {
    double v = 0;
    dm::barycentricGradients({mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]}, &v);
    volume += v;
  }
  for (const auto& x : mesh.nodes) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  EXPECT_NEAR(volume, 2.0, 1e-12);
  EXPECT_LT((lo - Vector3d(0, 0, 0)).norm(), 1e-12);
  EXPECT_LT((hi - Vector3d(2, 1, 1)).norm(), 1e-12);
  EXPECT_EQ(mesh.elements.size(), 6u * 4 * 2 * 2);
}

namespace {

// A 2 x 1 x 1 block held at x <= 0.4 and pulled at x >= 1.6.
core::Scenario pulledBlock() {
  core::Scenario s;
  s.name = "pulled_block";
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  core::Fixture clamp;
  clamp.name = "clamp";
  clamp.region = box(Vector3d(0, 0.5, 0.5), Vector3d(0.8, 2, 2));
  s.fixtures = {clamp};
  core::Load pull;
  pull.name = "pull";
  pull.region = box(Vector3d(2, 0.5, 0.5), Vector3d(0.8, 2, 2));
  pull.force = Vector3d(1e3, 0, 0);
  s.loads = {pull};
  return s;
}

// The block's 8 x 4 x 4 lattice with its interior particles moved to random places in the block
// (the surface particles stay on the faces, as a sampler leaves them).
core::ParticleCloud randomBlock(core::ParticleCloud cloud) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.volumes[i] > 0.0) cloud.positions[i] = Vector3d(2 * unit(rng), unit(rng), unit(rng));
  return cloud;
}

// The block with its surface particles' normals tilted by up to ~25 degrees, as a NeRF extraction's
// bumpy surface has them: the surface they describe is a patchwork of planes.
core::ParticleCloud bumpyBlock(core::ParticleCloud cloud) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> tilt(-0.45, 0.45);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    Vector3d& n = cloud.normals[i];
    if (n.squaredNorm() == 0.0) continue;
    n = (n + Vector3d(tilt(rng), tilt(rng), tilt(rng))).normalized();
  }
  return cloud;
}

// Surface particles without normals (a PLY that carries none) do not place the surface.
core::ParticleCloud withoutNormals(core::ParticleCloud cloud) {
  for (Vector3d& n : cloud.normals) n.setZero();
  return cloud;
}

}  // namespace

TEST(Simulate, FemOnParticlesReproducesUniaxialTraction) {
  // The voxel mesher over particles: their own cells, which a lattice fills exactly. (CGAL meshes
  // the surface they describe, whose chamfered edges leave the rollers' band:
  // FemOnASampledCloudMeshesTheBodyWhicheverSampler.)
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(4, 2, 2));
  const core::Scenario s = uniaxial(2e5, 2.0);
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  for (bool with_surface : {false, true}) {
    dm::SimulateOptions options;
    options.voxel.order = 1;
    options.mesher = dm::SimulateOptions::Mesher::kVoxel;
    if (with_surface) {
      options.surface = boxSurface(Vector3d(0, 0, 0), Vector3d(2, 1, 1));
      options.voxel.cell = 0.5;
    }
    const dm::SimulationOutcome out = dm::simulate(cloud, s, dm::SolverChoice::kFem, options);
    ASSERT_EQ(out.field.size(), cloud.size());
    double err = 0, largest = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Vector3d& X = cloud.positions[i];
      EXPECT_EQ(out.field.positions[i], X);  // same rows, same order
      const Vector3d exact((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
      err = std::max(err, (out.field.displacements[i] - exact).norm());
      largest = std::max(largest, exact.norm());
    }
    EXPECT_LT(err, 1e-7 * (a - 1) * 2.0) << (with_surface ? "surface mesh" : "particle cells");
    EXPECT_NEAR(out.max_displacement, largest, 1e-7);
    EXPECT_LT(out.energy, 0.0);  // a dead load does positive work: Pi = W - work < 0
    EXPECT_GT(out.mesh_elements, 0);
  }
}

TEST(Simulate, FemMeshesFromTheBodyReportsAndStopsOnTime) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4));
  const core::Scenario s = uniaxial(2e5, 2.0);
  dm::SimulateOptions options;
  options.voxel.order = 1;
  options.surface = boxSurface(Vector3d(0, 0, 0), Vector3d(2, 1, 1));
  std::vector<std::string> phases;
  options.control.progress_interval = 0.0;
  options.control.progress = [&](const dm::SolveProgress& p) { phases.push_back(p.phase); };
  const dm::SimulationOutcome out = dm::simulate(cloud, s, dm::SolverChoice::kFem, options);
  // The cell is the body's rule (thickness / elements_across), not the 0.25 particle spacing.
  dm::MeshSizeRule rule;
  rule.order = 1;
  EXPECT_DOUBLE_EQ(out.mesh_cell, dm::automaticCell(dm::measureSurface(*options.surface), rule));
  EXPECT_NE(out.mesh_cell, 0.25);
  ASSERT_GE(phases.size(), 4u);
  EXPECT_EQ(phases.front().rfind("mesh (CGAL, TET4, cell ", 0), 0u) << phases.front();
  // What the mesher made, before the solve it sets the cost of.
  EXPECT_EQ(phases[1], "meshed: " + std::to_string(out.mesh_elements) + " tetrahedra, " +
                           std::to_string(3 * out.mesh_nodes) + " dofs");
  EXPECT_EQ(phases[2], "newton");
  EXPECT_EQ(phases.back(), "done");
  // A budget spent before the solve stops it with the cause, not with a field.
  options.control.time_limit = 1e-9;
  try {
    dm::simulate(cloud, s, dm::SolverChoice::kFem, options);
    ADD_FAILURE() << "a spent time budget still gave a field";
  } catch (const dm::SolveError& e) {
    EXPECT_EQ(e.failure(), dm::SolveFailure::kTimeLimit) << e.what();
  }
}

// Automatic FEM voxels over particles: one spacing on a lattice, two on a random cloud, whose
// one-spacing cells are a third empty (holes, and voxels meeting only at an edge).
TEST(Simulate, FemVoxelsOfACloudWithoutNormalsSpanWholeSpacings) {
  const core::ParticleCloud grid =
      withoutNormals(dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4)));
  EXPECT_TRUE(dm::particlesFormALattice(grid));
  EXPECT_FALSE(dm::particlesDescribeSurface(grid));
  const core::ParticleCloud random = randomBlock(grid);
  EXPECT_FALSE(dm::particlesFormALattice(random));
  dm::SimulateOptions options;
  options.voxel.order = 1;
  // The body's rule asks for 1/6 m cells: a whole number of the 0.25 m spacing, at least two here.
  const dm::SimulationOutcome on_random = dm::simulate(random, pulledBlock(), dm::SolverChoice::kFem, options);
  EXPECT_NEAR(on_random.mesh_cell, 0.5, 1e-9);
  EXPECT_LT(on_random.energy, 0.0);
  const dm::SimulationOutcome on_grid = dm::simulate(grid, pulledBlock(), dm::SolverChoice::kFem, options);
  EXPECT_NEAR(on_grid.mesh_cell, 0.25, 1e-9);
}

TEST(ParticleSurface, ASampledBlockGivesTheBlockWhicheverSampler) {
  // The surface particles' tangent planes place the faces exactly; the random interior does not
  // matter. A lattice whose surface particles carry a cell of volume does not place its surface.
  const core::ParticleCloud grid = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4));
  const core::ParticleCloud random = randomBlock(grid);
  ASSERT_TRUE(dm::particlesDescribeSurface(random));
  // Faces exact, and the twelve edges where the faces' planes meet (sharpenEdges); without it
  // they are chamfered over about a step (16 m of edge, step 0.05 m: measured 2.5e-3 m^3 and
  // 0.12 m^2 short), which the edges now are not (8e-6 m^3, 1.5e-3 m^2: the corners).
  const core::TriangleMesh surface = dm::surfaceOfParticles(random, 0.05);
  const dm::BodyMeasures body = dm::measureSurface(surface);
  EXPECT_LT((body.lower - Vector3d(0, 0, 0)).norm(), 1e-9);
  EXPECT_LT((body.upper - Vector3d(2, 1, 1)).norm(), 1e-9);
  EXPECT_NEAR(body.volume, 2.0, 1e-4);
  EXPECT_NEAR(body.area, 10.0, 0.01);
  const dm::BodyMeasures chamfered = dm::measureSurface(dm::surfaceOfParticles(random, 0.05, false));
  EXPECT_LT(chamfered.volume, 2.0 - 1e-3);
  EXPECT_GT(chamfered.volume, 2.0 - 16 * 0.05 * 0.05);
  core::ParticleCloud cells = grid;
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (cells.areas[i] > 0.0) cells.volumes[i] = 0.25 * 0.25 * 0.25;
  EXPECT_FALSE(dm::particlesDescribeSurface(cells));
  EXPECT_THROW(dm::surfaceOfParticles(cells, 0.1), core::Error);
  EXPECT_THROW(dm::surfaceOfParticles(random, 0.0), core::Error);
}

TEST(Simulate, FemOnASampledCloudMeshesTheBodyWhicheverSampler) {
  // Without --mesh the FEM meshes the surface the particles describe: a random cloud gets the
  // answer of the lattice and of the block's own surface (TET10, the end faces held and pulled).
  // Before, the random cloud got blocks of two spacings that its particles half filled: on a
  // Poisson cuboid 16 blocks and 1.7x the energy; on random T-bar clouds 37 % off.
  const core::ParticleCloud grid = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4));
  const core::ParticleCloud random = randomBlock(grid);
  core::Scenario bent = pulledBlock();
  bent.fixtures[0].region = box(Vector3d(0, 0.5, 0.5), Vector3d(0.02, 2, 2));  // grips the x = 0 face
  bent.loads[0].region = box(Vector3d(2, 0.5, 0.5), Vector3d(0.02, 2, 2));
  bent.loads[0].force = Vector3d(0, 0, -2e4);
  dm::SimulateOptions options;
  const dm::SimulationOutcome on_random = dm::simulate(random, bent, dm::SolverChoice::kFem, options);
  const dm::SimulationOutcome on_grid = dm::simulate(grid, bent, dm::SolverChoice::kFem, options);
  options.surface = boxSurface(Vector3d(0, 0, 0), Vector3d(2, 1, 1));
  const dm::SimulationOutcome on_surface = dm::simulate(random, bent, dm::SolverChoice::kFem, options);
  // The same surface particles give the same surface, whatever lies inside.
  EXPECT_NEAR(on_random.energy / on_grid.energy, 1.0, 1e-6);
  // Measured 0.8 % in energy and 1.0 % rel. L2 from the exact box, whose edges the mesher keeps
  // (it protects a given surface's creases, not the sampled one's); with the particles' surface
  // chamfered, as before sharpenEdges(), 2.0 % and 2.2 %.
  EXPECT_NEAR(on_random.mesh_cell, on_surface.mesh_cell, 0.02 * on_surface.mesh_cell);
  EXPECT_LT(on_random.energy, 0.0);
  EXPECT_NEAR(on_random.energy / on_surface.energy, 1.0, 0.015);
  EXPECT_LT(dm::compareResults(on_random.field, on_surface.field).rel_l2, 0.02);
}

namespace {

// Tetrahedra of CGAL's mesh of the surface the cloud's particles describe, following it to a tenth
// of the cell as it follows a given surface.
std::size_t tetrahedraFollowingEveryBump(const core::ParticleCloud& cloud, const core::Scenario& scenario, double cell) {
  const core::TriangleMesh surface = dm::surfaceOfParticles(cloud, cell / 3.0);
  dm::CgalMeshConfig config;
  config.cell = cell;
  config.protect_creases = false;
  config.cut_planes = dm::heldVolumePlanes(scenario, surface);
  return dm::cgalMeshFromSurface(surface, config).elements.size();
}

}  // namespace

TEST(Simulate, TheFemFollowsTheParticlesSurfaceOnlyAsCloselyAsTheyPlaceIt) {
  // Bumps between the planes of particles coarser than the cell refined Mesh_3's surface far below
  // the cell (a 158-particle NeRF cuboid: 171k dofs for a 60k budget, a 40 s solve); a rough
  // surface is followed to a tenth of the spacing there, and to a tenth of the cell where the
  // particles are finer. (A flat-faced one keeps a tenth of the cell:
  // FemOnASampledCloudMeshesTheBodyWhicheverSampler, whose edges need it.)
  const core::ParticleCloud bumpy =
      bumpyBlock(dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(8, 4, 4)));
  const core::Scenario pulled = pulledBlock();
  dm::SimulateOptions options;
  options.voxel.cell = 0.1;  // the particles' spacing is 0.25
  const dm::SimulationOutcome coarse = dm::simulate(bumpy, pulled, dm::SolverChoice::kFem, options);
  EXPECT_LT(coarse.mesh_elements, 0.7 * tetrahedraFollowingEveryBump(bumpy, pulled, 0.1));
  EXPECT_LT(coarse.energy, 0.0);
  options.voxel.cell = 0.5;
  const dm::SimulationOutcome fine = dm::simulate(bumpy, pulled, dm::SolverChoice::kFem, options);
  EXPECT_NEAR(fine.mesh_elements / static_cast<double>(tetrahedraFollowingEveryBump(bumpy, pulled, 0.5)), 1.0, 0.03);
}

TEST(Simulate, DemGivesOneRowPerParticleInOrder) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  dm::SimulateOptions options;
  options.dem.network.width = 8;
  options.dem.network.depth = 1;
  options.dem.adam.iterations = 0;
  options.dem.output_newton.enabled = true;  // a Ritz solve in the network's basis: converged at once
  options.dem.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  options.dem.threads = 1;
  const dm::SimulationOutcome out = dm::simulate(cloud, uniaxial(1e5, 1.0), dm::SolverChoice::kDem, options);
  ASSERT_EQ(out.field.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(out.field.positions[i], cloud.positions[i]);
  EXPECT_GT(out.max_displacement, 0.0);
  EXPECT_TRUE(std::isfinite(out.energy));
}

TEST(Simulate, PinnRunsAndBadInputFailsFirst) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(2, 2, 2));
  dm::SimulateOptions options;
  options.pinn.width = 8;
  options.pinn.depth = 1;
  options.pinn.adam_iterations = 20;
  options.pinn.lbfgs_iterations = 5;
  options.pinn.threads = 1;
  const dm::SimulationOutcome out = dm::simulate(cloud, uniaxial(1e5, 1.0), dm::SolverChoice::kPinn, options);
  ASSERT_EQ(out.field.size(), cloud.size());
  EXPECT_GT(out.max_displacement, 0.0);
  options.pinn.weight_residual = std::nan("");
  EXPECT_THROW(dm::simulate(cloud, uniaxial(1e5, 1.0), dm::SolverChoice::kPinn, options), core::Error);
  EXPECT_THROW(dm::parseSolverChoice("xfem"), core::Error);
  core::Scenario s = uniaxial(1e5, 1.0);
  s.fixtures.clear();
  EXPECT_THROW(dm::simulate(cloud, s, dm::SolverChoice::kFem), core::Error);
}

TEST(CompareResults, ErrorsAndRefusals) {
  core::ResultField ref;
  for (int i = 0; i < 4; ++i) {
    ref.positions.emplace_back(i, 0, 0);
    ref.displacements.emplace_back(0, 0.1 * i, 0);
    ref.von_mises.push_back(1.0);
  }
  core::ResultField r = ref;
  EXPECT_DOUBLE_EQ(dm::compareResults(r, ref).rel_l2, 0.0);
  for (auto& u : r.displacements) u *= 1.1;
  const dm::ResultComparison c = dm::compareResults(r, ref);
  EXPECT_NEAR(c.rel_l2, 0.1, 1e-12);
  EXPECT_NEAR(c.max_error, 0.03, 1e-12);
  EXPECT_EQ(c.rows, 4u);
  core::ResultField shorter = ref;
  shorter.resize(3);
  EXPECT_THROW(dm::compareResults(shorter, ref), core::Error);
  core::ResultField moved = ref;
  moved.positions[2].x() += 1e-4;  // 3.3e-5 of the bounding box
  EXPECT_THROW(dm::compareResults(moved, ref), core::Error);
  moved.positions[2].x() = 2.0 + 1e-9;  // round-off of a PLY float round trip is fine
  EXPECT_NO_THROW(dm::compareResults(moved, ref));
  core::ResultField zero = ref;
  for (auto& u : zero.displacements) u.setZero();
  EXPECT_THROW(dm::compareResults(r, zero), core::Error);
}

}  // namespace
