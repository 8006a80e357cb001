// The default DEM's load quadrature (surface_loads.hpp): a load spread evenly over the surface the
// particles describe, whichever sampler placed them, and the twist it fixed on random clouds.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "box_region.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/surface_loads.hpp"
#include "random_surface_box.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using dm::test::box;
using Eigen::Vector3d;

namespace {

// The matrix's cuboid twist (config/scenarios/cuboid_twist.yaml): 0.125 x 0.1 x 0.1 m, the x = 0 face
// clamped, 8 N m about x on the x = 0.125 end (the region also takes 5 mm of the four sides).
const Vector3d kLower(0, -0.05, -0.05), kUpper(0.125, 0.05, 0.05);

core::Scenario cuboidTwist() {
  core::Scenario s;
  s.name = "cuboid_twist";
  s.material.youngs_modulus = 5e5;
  s.material.poisson_ratio = 0.4;
  s.load_steps = 1;
  core::Fixture clamp;
  clamp.name = "fixed_end";
  clamp.region = box(Vector3d(0, 0, 0), Vector3d(0.01, 0.12, 0.12));
  s.fixtures.push_back(clamp);
  core::Load twist;
  twist.name = "twisted_end";
  twist.region = box(Vector3d(0.125, 0, 0), Vector3d(0.01, 0.12, 0.12));
  twist.torque = Vector3d(8, 0, 0);
  s.loads.push_back(twist);
  return s;
}

// The torque about x that the forces on the loaded end face (x > 124.9 mm) carry in each of 4 x 4
// bins of 25 mm across it.
Eigen::Matrix4d endFaceTorques(const std::vector<Vector3d>& points, const std::vector<Vector3d>& forces) {
  Eigen::Matrix4d bins = Eigen::Matrix4d::Zero();
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Vector3d& x = points[k];
    if (x(0) < 0.1249) continue;
    const int j = std::clamp(static_cast<int>((x(1) + 0.05) / 0.025), 0, 3);
    const int i = std::clamp(static_cast<int>((x(2) + 0.05) / 0.025), 0, 3);
    bins(j, i) += x.cross(forces[k])(0);
  }
  return bins;
}

Eigen::Matrix4d particleEndFaceTorques(const core::Scenario& s, const core::ParticleCloud& cloud) {
  const std::vector<Vector3d> t = dm::particleTractions(s, cloud);
  std::vector<Vector3d> forces;
  for (std::size_t i = 0; i < cloud.size(); ++i) forces.push_back(cloud.areas[i] * t[i]);
  return endFaceTorques(cloud.positions, forces);
}

// The loads' total force and torque about the origin.
void resultants(const dm::SurfaceLoads& loads, Vector3d& force, Vector3d& torque) {
  force = torque = Vector3d::Zero();
  for (std::size_t k = 0; k < loads.points.size(); ++k) {
    force += loads.forces[k];
    torque += loads.points[k].cross(loads.forces[k]);
  }
}

}  // namespace

TEST(SurfaceLoads, SpreadTheWrenchEvenlyWhateverTheSurfaceParticles) {
  // 36 random particles on the loaded end, a lattice of 6 x 6 on the other cloud. On the particles
  // the 16 bins' torques differ by up to half the largest; on the surface they agree to 1 %.
  const core::Scenario s = cuboidTwist();
  const core::ParticleCloud random = dm::test::randomSurfaceBox(kLower, kUpper, 1.0 / 60, 3);
  const core::ParticleCloud lattice = dm::makeBoxParticles(kLower, kUpper, Eigen::Vector3i(8, 6, 6));
  const double step = 0.0128 / 8;  // the default DEM's: its cell (600 body cells) / 8
  const dm::SurfaceLoads a = dm::surfaceLoads(s, random, step), b = dm::surfaceLoads(s, lattice, step);
  Vector3d force, torque;
  resultants(a, force, torque);
  EXPECT_LT(force.norm(), 1e-9);
  EXPECT_LT((torque - Vector3d(8, 0, 0)).norm(), 1e-9);
  const Eigen::Matrix4d on_random = endFaceTorques(a.points, a.forces), on_lattice = endFaceTorques(b.points, b.forces);
  const double largest = on_lattice.cwiseAbs().maxCoeff();
  const double particles_apart = (particleEndFaceTorques(s, random) - on_lattice).cwiseAbs().maxCoeff() / largest;
  const double surface_apart = (on_random - on_lattice).cwiseAbs().maxCoeff() / largest;
  std::cout << "end-face bins' torque, random vs lattice cloud: on the particles " << particles_apart
            << ", on the surface " << surface_apart << " of the largest bin\n";
  EXPECT_GT(particles_apart, 0.2);  // what the particles' own loads did
  EXPECT_LT(surface_apart, 0.01);
  // The end face itself carries its exact share: 16.7 of the patch's 23.3 (x 1e-6 m^4) polar moment,
  // the 5 mm strips of the sides the rest (some of it on the end face's rim, within a step).
  EXPECT_NEAR(on_random.sum() / 8.0, 16.667 / 23.333, 0.03);
}

TEST(SurfaceLoads, TheTwistOnRandomSurfaceParticlesHasTheLatticesEnergy) {
  // The default DEM on the cuboid twist: random surface particles (a sampler's clumps and gaps)
  // against a lattice of the same spacing. With the loads on the particles the random cloud was
  // 8.5 % lower in energy (-1.621 J against -1.494 J: its uneven point loads do extra work on the
  // grid's dimples under them), as the matrix's random clouds were against the FEM (-3.2 % at 1/6).
  const core::Scenario s = cuboidTwist();
  double energy[2];
  const core::ParticleCloud clouds[2] = {dm::test::randomSurfaceBox(kLower, kUpper, 1.0 / 60, 3),
                                         dm::makeBoxParticles(kLower, kUpper, Eigen::Vector3i(8, 6, 6))};
  for (int c = 0; c < 2; ++c) {
    dm::DemConfig config;
    config.threads = 1;
    config.grid.body_cells = 200;  // 18 mm cells: a quarter of the default's unknowns
    dm::DemSolver dem(clouds[c], s, config);
    energy[c] = dem.solve().energy;
  }
  std::cout << "cuboid twist energy: random surface " << energy[0] << " J, lattice " << energy[1] << " J\n";
  EXPECT_LT(energy[1], 0.0);
  EXPECT_NEAR(energy[0] / energy[1], 1.0, 0.01);
}

TEST(SurfaceLoads, OtherRegionsCarryTheExactWrenchToo) {
  // A half-space beyond x = 120 mm loads the same patch as the box; a sphere finer than the lattice
  // around one surface particle keeps that particle's force.
  core::Scenario s = cuboidTwist();
  const core::ParticleCloud cloud = dm::test::randomSurfaceBox(kLower, kUpper, 1.0 / 60, 3);
  Vector3d force, torque;
  s.loads[0].region.type = core::Region::Type::kHalfspace;
  s.loads[0].region.center = Vector3d(0.12, 0, 0);
  s.loads[0].region.normal = Vector3d(-1, 0, 0);
  const dm::SurfaceLoads half = dm::surfaceLoads(s, cloud, 0.0016);
  resultants(half, force, torque);
  EXPECT_LT(force.norm(), 1e-9);
  EXPECT_LT((torque - Vector3d(8, 0, 0)).norm(), 1e-9);
  std::size_t surface = 0;
  while (!(cloud.areas[surface] > 0)) ++surface;
  s.loads[0].region.type = core::Region::Type::kSphere;
  s.loads[0].region.center = cloud.positions[surface];
  s.loads[0].region.radius = 1e-6;
  s.loads[0].force = Vector3d(0, 0, 3);
  s.loads[0].torque.setZero();
  const dm::SurfaceLoads tiny = dm::surfaceLoads(s, cloud, 0.0016);
  ASSERT_EQ(tiny.points.size(), 1u);
  EXPECT_EQ(tiny.points[0], cloud.positions[surface]);
  EXPECT_LT((tiny.forces[0] - Vector3d(0, 0, 3)).norm(), 1e-12);
}
