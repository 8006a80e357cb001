// What a fixture holds (held_face.hpp): a thick box band clamps the body's face, not the band's
// volume, in the DEM's lift and in the FEM's nodes alike.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/reference_problems.hpp"

#include "box_region.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

using demnerf::mechanics::test::box;

// A roller (one component) or clamp on the unit cube's face axis = at, found by a box band
// `thickness` thick centred on the face.
core::Fixture band(const std::string& name, int axis, double at, double thickness, double value = 0.0) {
  core::Fixture f;
  f.name = name;
  Vector3d c(0.5, 0.5, 0.5), s(1.4, 1.4, 1.4);
  c(axis) = at;
  s(axis) = thickness;
  f.region = box(c, s);
  f.constrained = Eigen::Vector3i::Zero();
  f.constrained(axis) = 1;
  f.displacement(axis) = value;
  return f;
}

// The unit cube on three rollers, pulled to 40 % strain at x = 1, every fixture a band 0.3 thick:
// held as faces its answer is homogeneous; held as volumes the band's strips on the four sides
// (and its interior nodes) would be pinned.
core::Scenario thickBandStretch() {
  core::Scenario s;
  s.name = "thick_band_stretch";
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  s.load_steps = 2;
  s.fixtures = {band("x0", 0, 0.0, 0.3), band("y0", 1, 0.0, 0.3), band("z0", 2, 0.0, 0.3), band("pull", 0, 1.0, 0.3, 0.4)};
  return s;
}

}  // namespace

TEST(HeldFace, AThickBandHoldsTheFaceAndFreesTheBand) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(0.1, 0.1, 0.1), Eigen::Vector3i(10, 10, 10));
  core::Scenario s;
  core::Fixture clamp;
  clamp.name = "clamp";
  clamp.region = box(Vector3d(0, 0.05, 0.05), Vector3d(0.01, 0.12, 0.12));  // x <= 5 mm: face and 5 mm strips
  s.fixtures = {clamp};
  const std::vector<dm::HeldFace> held = dm::heldFaces(s, cloud);
  ASSERT_EQ(held.size(), 1u);
  ASSERT_TRUE(held[0].valid);
  EXPECT_NEAR(held[0].normal.x(), -1.0, 1e-12);
  EXPECT_NEAR(held[0].point.x(), 0.0, 1e-12);
  EXPECT_EQ(held[0].polygon.size(), 4u);  // the box's 120 x 120 mm section
  const double length = 0.2;
  Vector3d g, D;
  Eigen::Matrix3d gg, gD;
  const auto liftD = [&](const Vector3d& x, const std::vector<dm::HeldFace>* faces) {
    dm::dirichletLiftAt(s, x, length, g, gg, D, gD, faces);
    return D;
  };
  // Zero on the clamped face (also at its rim), positive under it and on the sides' strips.
  EXPECT_EQ(liftD(Vector3d(0, 0.05, 0.05), &held).norm(), 0.0);
  EXPECT_EQ(liftD(Vector3d(0, 0.1, 0.0), &held).norm(), 0.0);
  EXPECT_NEAR(liftD(Vector3d(0.003, 0.05, 0.05), &held)(0), 0.003 / length, 1e-12);
  EXPECT_NEAR(liftD(Vector3d(0.003, 0.1, 0.05), &held)(1), 0.003 / length, 1e-12);
  // The volume meaning (no faces) pins the whole band.
  EXPECT_EQ(liftD(Vector3d(0.003, 0.05, 0.05), nullptr).norm(), 0.0);
  // The penalty DEM and the PINN hold the face's 100 surface particles, not the 240 particles in
  // the band (those plus the 40 side particles and 100 interior ones at x = 5 mm).
  EXPECT_EQ(dm::resolveFixtures(s, cloud.positions).index.size(), 240u);
  const dm::Dirichlet particles = dm::resolveHeldParticles(s, cloud, held);
  EXPECT_EQ(particles.index.size(), 100u);
  for (int i : particles.index) EXPECT_EQ(cloud.positions[i].x(), 0.0);
  // D's gradient inside the band (where the old distance was flat) is the face's normal direction.
  const Vector3d x(0.004, 0.03, 0.07);
  liftD(x, &held);
  const Eigen::Matrix3d analytic = gD;
  for (int k = 0; k < 3; ++k) {
    const Vector3d h = 1e-7 * Vector3d::Unit(k);
    const Vector3d fd = (liftD(x + h, &held) - liftD(x - h, &held)) / 2e-7;
    EXPECT_LT((fd - analytic.col(k)).norm(), 1e-6) << "axis " << k;
  }
  EXPECT_NEAR(analytic(0, 0), 1.0 / length, 1e-12);
}

TEST(HeldFace, RegionsWithoutADominantFaceHoldTheirVolume) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(0.1, 0.1, 0.1), Eigen::Vector3i(10, 10, 10));
  core::Scenario s;
  core::Fixture corner, sphere, grip;
  corner.name = "corner";  // three faces of equal area
  corner.region = box(Vector3d(0, 0, 0), Vector3d(0.06, 0.06, 0.06));
  sphere.name = "sphere";
  sphere.region.type = core::Region::Type::kSphere;
  sphere.region.center = Vector3d(0, 0.05, 0.05);
  sphere.region.radius = 0.02;
  grip.name = "deep grip";  // 40 mm of the four sides against the 100 x 100 mm end
  grip.region = box(Vector3d(0, 0.05, 0.05), Vector3d(0.08, 0.12, 0.12));
  s.fixtures = {corner, sphere, grip};
  const std::vector<dm::HeldFace> held = dm::heldFaces(s, cloud);
  ASSERT_EQ(held.size(), 3u);
  for (const dm::HeldFace& f : held) EXPECT_FALSE(f.valid);
  const dm::FaceCluster cluster = dm::dominantFace({Vector3d::UnitX(), Vector3d::UnitY(), -Vector3d::UnitX()}, {1, 1, 2});
  EXPECT_NEAR(cluster.share, 0.5, 1e-12);
  EXPECT_NEAR(cluster.normal.x(), -1.0, 1e-12);
}

// A rough face (a NeRF extraction's base): a sawtooth 3 mm deep, rising over 9 mm and falling over
// 3 mm, sampled evenly with equal areas, as the samplers do. Three quarters of the samples sit on
// the gentle slopes, so their normals lean 18 degrees and the steep ones fall out of the cluster:
// the mean normal leaned the face by as much (one side of the base unheld). The plane through the
// samples' positions is the face's: level within the sawtooth's phase.
TEST(HeldFace, ARoughFaceIsHeldOnThePlaneOfItsPointsNotItsMeanNormal) {
  std::vector<Vector3d> points, normals;
  std::vector<double> areas;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 60; ++j) {
      const double y = (j + 0.5) * 1e-3, phase = std::fmod(y, 0.012);
      const bool rising = phase < 0.009;
      const double slope = rising ? 1.0 / 3.0 : -1.0;
      const double z = rising ? phase / 3.0 : 0.003 - (phase - 0.009);
      points.emplace_back((i + 0.5) * 6e-3, y, z);
      normals.push_back(Vector3d(0.0, slope, -1.0).normalized());  // outward (down) from the body above
      areas.push_back(6e-6);
    }
  const dm::FaceCluster cluster = dm::dominantFace(normals, areas);
  EXPECT_GT(std::abs(cluster.normal.y()), 0.2) << "the samples' normals lean (what the plane fit corrects)";
  const core::Region base = box(Vector3d(0.03, 0.03, 0.0), Vector3d(0.08, 0.08, 0.01));
  const dm::HeldFace face = dm::fitHeldFace(base, points, normals, areas);
  ASSERT_TRUE(face.valid);
  EXPECT_LT(std::abs(face.normal.y()), 0.02);  // 0.0075: the phase of 5 whole periods
  EXPECT_LT(std::abs(face.normal.x()), 1e-9);
  EXPECT_LT(face.normal.z(), -0.999);
  EXPECT_GT(face.point.z(), 0.0);  // on the sawtooth's mean height, not below the body
  EXPECT_LT(face.point.z(), 0.003);
}

TEST(HeldFace, FemThickBandsClampFacesSoTheStretchStaysHomogeneous) {
  const core::Scenario s = thickBandStretch();
  // 4 x 4 x 4 TET10: the bands (0.15 deep) hold the mid-edge nodes 0.125 in from each face.
  const dm::TetMesh mesh = dm::structuredBoxMesh(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(4, 4, 4), 2);
  const dm::Dirichlet volume = dm::resolveFixtures(s, mesh.nodes);
  const dm::Dirichlet faces = dm::resolveMeshFixtures(s, mesh, dm::boundaryFaces(mesh));
  EXPECT_LT(faces.index.size(), volume.index.size());
  dm::FemSolver solver(mesh, s);
  const dm::FemResult& r = solver.solve();
  const double b = dm::uniaxialLateralStretch(*dm::makeMaterial(s.material), 1.4);
  double worst = 0.0;
  for (std::size_t i = 0; i < solver.mesh().nodes.size(); ++i) {
    const Vector3d& X = solver.mesh().nodes[i];
    worst = std::max(worst, (r.displacement[i] - Vector3d(0.4 * X.x(), (b - 1) * X.y(), (b - 1) * X.z())).norm());
  }
  EXPECT_LT(worst, 1e-8);
}

TEST(HeldFace, DemThickBandsClampFacesSoTheStretchStaysHomogeneous) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(12, 12, 12));
  const core::Scenario s = thickBandStretch();
  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.adam.iterations = 0;
  config.grid.cell = 0.34;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport report = dem.solve();
  const double b = dm::uniaxialLateralStretch(*dm::makeMaterial(s.material), 1.4);
  const auto u = dem.predict(cloud.positions);
  double err = 0, ref = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& X = cloud.positions[i];
    const Vector3d exact(0.4 * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err = std::max(err, (u[i] - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  std::cout << "DEM, 0.3-thick bands on the unit cube: max rel error " << err / ref << " in " << report.seconds << " s\n";
  EXPECT_LT(err / ref, 0.01);
}

// The MLP alone continues its lift linearly through a held face (dirichletLift's signed_faces):
// beyond the face the distance is negative, so D keeps its formula on both sides of x = 0 instead
// of folding to |x|, and the homogeneous stretch stays D times a smooth function.
TEST(HeldFace, SignedDistanceContinuesThroughTheFace) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = thickBandStretch();
  const std::vector<dm::HeldFace> held = dm::heldFaces(s, cloud);
  ASSERT_TRUE(held[0].valid);
  Vector3d grad;
  const Vector3d beyond(-0.02, 0.4, 0.6), within(0.02, 0.4, 0.6);
  EXPECT_NEAR(dm::heldFaceDistance(held[0], beyond, grad), 0.02, 1e-12);  // folded back: |x|
  EXPECT_NEAR(dm::heldFaceDistance(held[0], beyond, grad, true), -0.02, 1e-12);
  EXPECT_NEAR(grad.x(), 1.0, 1e-12);
  EXPECT_NEAR(dm::heldFaceDistance(held[0], within, grad, true), 0.02, 1e-12);
  // D_x = x (1 - x) (the roller at x = 0 times the pull at x = 1), its gradient 1 - 2x, on both sides.
  const dm::DirichletLift lift = dm::dirichletLift(s, {beyond, within}, 1.0, &held, true);
  EXPECT_NEAR(lift.D[0].x(), -0.02 * 1.02, 1e-12);
  EXPECT_NEAR(lift.D[1].x(), 0.02 * 0.98, 1e-12);
  EXPECT_NEAR(lift.grad_D[0](0, 0), 1.04, 1e-12);
  EXPECT_NEAR(lift.grad_D[1](0, 0), 0.96, 1e-12);
  // The pull's lift g_x = 0.4 x between x = 0 and x = 1 continues past both faces.
  const dm::DirichletLift ends = dm::dirichletLift(s, {Vector3d(-0.02, 0.5, 0.5), Vector3d(1.02, 0.5, 0.5)}, 1.0, &held, true);
  EXPECT_NEAR(ends.g[0].x(), -0.008, 1e-12);
  EXPECT_NEAR(ends.g[1].x(), 0.408, 1e-12);
}

// Particles whose volumes exceed their lattice's hull (a sampler's estimate, like the random and
// Poisson clouds') move the MLP's cell quadrature out by a few hundredths, beyond the rollers.
// With |distance| the lift folded there: on this cube the training drifted into an exploit of its
// Gauss points and the solve was refused (the compression cube's random and Poisson clouds: 6.6 %
// off, or refused). Continued through the faces: the homogeneous answer within 1.9 % (max) after
// 300 iterations.
TEST(HeldFace, MlpHoldsTheStretchWithGaussPointsBeyondItsRollers) {
  core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  for (double& v : cloud.volumes) v *= 1.15;  // the cell quadrature's surface moves out ~0.025
  const core::Scenario s = thickBandStretch();
  dm::DemConfig config = dm::paperDemConfig();
  config.lbfgs.iterations = 300;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  dm::DemReport report;
  ASSERT_NO_THROW(report = dem.solve());  // |distance|: refused, the guard kept an earlier state
  const double b = dm::uniaxialLateralStretch(*dm::makeMaterial(s.material), 1.4);
  const auto u = dem.predict(cloud.positions);
  double err = 0, ref = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& X = cloud.positions[i];
    const Vector3d exact(0.4 * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err = std::max(err, (u[i] - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  std::cout << "MLP alone, stretched cube, quadrature beyond the rollers: max rel error " << err / ref << " in "
            << report.seconds << " s\n";
  EXPECT_LT(err / ref, 0.03);
}
