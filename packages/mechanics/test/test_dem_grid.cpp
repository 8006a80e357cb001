// The DEM's B-spline feature grid: the basis itself, its Newton solve, and the DEM that uses it.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <unistd.h>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

#include "box_region.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

using demnerf::mechanics::test::box;

// A 60 x 60 x 240 mm soft bar clamped at its base face and twisted by a torque on its top face.
core::Scenario twistedBar(double torque) {
  core::Scenario s;
  s.name = "twisted_bar";
  s.material.youngs_modulus = 5e5;
  s.material.poisson_ratio = 0.4;
  s.load_steps = 1;
  core::Fixture base;
  base.name = "base";
  base.region = box(Vector3d(0, 0, 0), Vector3d(0.08, 0.08, 0.002));
  s.fixtures.push_back(base);
  core::Load top;
  top.name = "top";
  top.region = box(Vector3d(0, 0, 0.24), Vector3d(0.08, 0.08, 0.002));
  top.torque = Vector3d(0, 0, torque);
  s.loads.push_back(top);
  return s;
}

double relativeL2(const std::vector<Vector3d>& u, const std::vector<Vector3d>& ref) {
  double e = 0, r = 0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    e += (u[i] - ref[i]).squaredNorm();
    r += ref[i].squaredNorm();
  }
  return std::sqrt(e / r);
}

}  // namespace

TEST(BsplineGrid, PartitionOfUnityAndGradientsMatchFiniteDifferences) {
  for (int degree = 1; degree <= 3; ++degree) {
    const dm::BsplineGrid grid(Vector3d(-0.1, 0.0, 0.2), Vector3d(0.2, 0.05, 0.4), 0.03, degree);
    const int S = grid.supportSize();
    ASSERT_EQ(S, (degree + 1) * (degree + 1) * (degree + 1));
    std::vector<long> nodes(S), nodes_h(S);
    std::vector<double> N(S), Nh(S);
    std::vector<Vector3d> dN(S), unused(S);
    for (const Vector3d& x : {Vector3d(0.011, 0.02, 0.33), Vector3d(-0.09, 0.049, 0.21), Vector3d(0.19, 0.001, 0.39)}) {
      grid.evaluate(x, nodes.data(), N.data(), dN.data());
      double sum = 0;
      Vector3d grad_sum = Vector3d::Zero();
      for (int s = 0; s < S; ++s) {
        EXPECT_GE(nodes[s], 0);
        EXPECT_LT(nodes[s], grid.nodeCount());
        EXPECT_GE(N[s], 0.0);
        sum += N[s];
        grad_sum += dN[s];
      }
      EXPECT_NEAR(sum, 1.0, 1e-12) << "degree " << degree;
      EXPECT_LT(grad_sum.norm(), 1e-9) << "degree " << degree;
      // Central differences inside the same cell (the pieces are polynomials there).
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k) {
        Vector3d xp = x, xm = x;
        xp(k) += h;
        xm(k) -= h;
        std::vector<double> Np(S), Nm(S);
        grid.evaluate(xp, nodes_h.data(), Np.data(), unused.data());
        ASSERT_EQ(nodes_h, nodes);
        grid.evaluate(xm, nodes_h.data(), Nm.data(), unused.data());
        ASSERT_EQ(nodes_h, nodes);
        for (int s = 0; s < S; ++s) EXPECT_NEAR(dN[s](k), (Np[s] - Nm[s]) / (2 * h), 1e-6) << "degree " << degree;
      }
    }
  }
  EXPECT_THROW(dm::BsplineGrid(Vector3d::Zero(), Vector3d::Ones(), 0.1, 4), core::Error);
  EXPECT_THROW(dm::BsplineGrid(Vector3d::Zero(), Vector3d::Ones(), 0.0, 2), core::Error);
}

TEST(DemGrid, NewtonOnTheGridSolvesTheUniaxialStretch) {
  // Newton alone, without a single Adam step, from u = 0 (100 % off). What is left is the particle
  // discretisation of the loaded face: max error 1.8 % at 6^3 particles, 0.6 % at 12^3 (any grid
  // cell from 0.2 to 0.5).
  const core::ParticleCloud cloud =
      dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(12, 12, 12));
  const core::Scenario s = dm::uniaxialTractionScenario(2e5);
  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.adam.iterations = 0;
  config.grid.cell = 0.34;
  config.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;  // the cells' rule: below
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  const auto u = dem.predict(cloud.positions);
  double err = 0, ref = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& X = cloud.positions[i];
    const Vector3d exact((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err = std::max(err, (u[i] - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  std::cout << "DEM grid Newton, uniaxial: max rel error " << err / ref << " in " << r.seconds << " s\n";
  EXPECT_LT(err / ref, 0.01);
  EXPECT_GT(r.min_J, 0.0);
}

TEST(DemGrid, TwistedBarAgreesWithQuadraticFem) {
  // A non-homogeneous case (5 degrees of twist) that needs the warping of the square section: the
  // grid DEM on 5 mm particles against TET10 on 15 mm (within 0.4 % of TET10 on 10 mm here).
  // Measured 1.3 %; 4.2 % from 7.5 mm particles (without the surface share), and garbage (80 %)
  // when the grid cell equals the particle spacing, which the solver refuses.
  const core::Scenario s = twistedBar(0.12);
  const core::ParticleCloud cloud =
      dm::makeBoxParticles(Vector3d(-0.03, -0.03, 0), Vector3d(0.03, 0.03, 0.24), Eigen::Vector3i(12, 12, 48));
  dm::VoxelMeshConfig voxel;
  voxel.cell = 0.015;
  voxel.order = 2;
  dm::FemSolver fem(dm::voxelMeshFromSurface(dm::boxSurface(Vector3d(-0.03, -0.03, 0), Vector3d(0.03, 0.03, 0.24)), voxel),
                    s);
  fem.solve();
  const auto reference = fem.interpolate(cloud.positions).displacement;

  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.adam.iterations = 0;
  config.grid.cell = 0.015;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  const double error = relativeL2(dem.predict(cloud.positions), reference);
  double top = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) top = std::max(top, reference[i].norm());
  std::cout << "DEM grid vs FEM TET10, twisted bar: rel L2 " << error << " in " << r.seconds << " s (max |u| " << top
            << " m)\n";
  EXPECT_GT(top, 0.003);  // the bar really twists
  EXPECT_LT(error, 0.03);
}

TEST(DemGrid, NestedSolveEndsAtTheGridsOwnMinimiser) {
  // grid.nested_levels only changes where the grid's Newton starts (a coarser grid's answer): the
  // answer must be the same minimiser as the direct solve's, to the Newton's tolerance.
  const core::Scenario s = twistedBar(0.12);
  const core::ParticleCloud cloud =
      dm::makeBoxParticles(Vector3d(-0.03, -0.03, 0), Vector3d(0.03, 0.03, 0.24), Eigen::Vector3i(12, 12, 48));
  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.grid.cell = 0.015;
  config.grid.nested_levels = 0;  // the default is nested: the direct solve must not be
  config.threads = 1;
  dm::DemSolver direct(cloud, s, config);
  const dm::DemReport a = direct.solve();
  config.grid.nested_levels = 1;
  config.grid.nested_ratio = 2.0;
  dm::DemSolver nested(cloud, s, config);
  const dm::DemReport b = nested.solve();
  EXPECT_LT(a.energy, 0.0);
  EXPECT_NEAR(b.energy, a.energy, 1e-7 * std::abs(a.energy));
  EXPECT_LT(relativeL2(nested.predict(cloud.positions), direct.predict(cloud.positions)), 1e-5);
  EXPECT_LE(b.residual, 1e-6);
}

TEST(DemGrid, SavedGridModelsPredictExactlyAsBefore) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(4, 4, 4));
  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.adam.iterations = 5;  // the MLP's share is not zero either
  config.grid.cell = 0.4;
  config.threads = 1;
  dm::DemSolver dem(cloud, dm::uniaxialTractionScenario(1e5), config);
  dem.solve();
  const std::string path = ::testing::TempDir() + "dem_grid_model_" + std::to_string(::getpid()) + ".dem";
  dm::saveDemModel(dem, path);
  const dm::DemSolver loaded = dm::loadDemModel(path);
  std::remove(path.c_str());
  const std::vector<Vector3d> points = {Vector3d(0.2, 0.3, 0.4), Vector3d(0.9, 0.1, 0.5), Vector3d(1.0, 1.0, 1.0)};
  const auto a = dem.predict(points), b = loaded.predict(points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_GT(a[i].norm(), 1e-4);
    EXPECT_LT((a[i] - b[i]).norm(), 1e-12 + 1e-6 * a[i].norm());
  }
  EXPECT_EQ(loaded.state().grid_coefficients, dem.state().grid_coefficients);
}

TEST(DemGrid, UnsupportedCombinationsFailBeforeTraining) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  const core::Scenario s = dm::uniaxialTractionScenario(1e5);
  dm::DemConfig config;
  config.grid.cell = 0.4;
  config.parametric.enabled = true;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
  config.parametric.enabled = false;
  config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
  config.boundary.kind = dm::DemConfig::Boundary::kExact;
  config.grid.cell = -1;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
  config.grid.cell = 0.3;  // the particle spacing: too fine for the particle quadrature
  config.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
  config.grid.cell = 0.15;  // 0.45 particle spacings: finer than the cells' rule takes (0.6)
  config.grid.quadrature = dm::DemConfig::GridQuadrature::kCells;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
  config.grid.cell = 0.4;
  config.grid.degree = 5;
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
}

TEST(DemGrid, NewtonThatDoesNotConvergeIsReportedNotReturned) {
  // One Newton iteration never confirms convergence: every load step fails, is halved, and the
  // solve ends in an error that says what to change instead of a half-solved field.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(4, 4, 4));
  dm::DemConfig config;
  config.network.width = 8;
  config.network.depth = 2;
  config.adam.iterations = 0;
  config.grid.cell = 0.5;
  config.grid.newton_iterations = 1;
  config.max_halvings = 2;
  config.threads = 1;
  dm::DemSolver dem(cloud, dm::uniaxialTractionScenario(1e5), config);
  try {
    dem.solve();
    ADD_FAILURE() << "no error for a Newton solve that never converged";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("grid_newton_iterations"), std::string::npos) << e.what();
  }
}

TEST(DemGrid, SimpleShearMatchesTheClosedFormWithAndWithoutTheGrid) {
  // u = (gamma Y, 0, 0): bottom face held, top face moved by gamma along x, and the x faces carry
  // the homogeneous state's traction P e1 = (0, mu gamma, 0) (J = 1, so P = mu (F - F^-T)); the z
  // faces are traction-free there. A wrong energy, traction or lift drifts away from it.
  const double gamma = 0.3;
  core::Scenario s;
  s.name = "simple_shear";
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  const double mu = dm::makeMaterial(s.material)->mu();
  for (const double y : {0.0, 1.0}) {
    core::Fixture f;
    f.name = y == 0.0 ? "bottom" : "top";
    f.region = box(Vector3d(0.5, y, 0.5), Vector3d(2, 1e-6, 2));
    f.displacement = Vector3d(gamma * y, 0, 0);
    s.fixtures.push_back(f);
  }
  for (const double x : {0.0, 1.0}) {
    core::Load l;
    l.name = x == 0.0 ? "left" : "right";
    l.region = box(Vector3d(x, 0.5, 0.5), Vector3d(1e-6, 2, 2));
    l.force = Vector3d(0, (x == 0.0 ? -1.0 : 1.0) * mu * gamma, 0);  // traction x unit face area
    s.loads.push_back(l);
  }
  for (const bool grid : {false, true}) {
    // The grid's Newton solve sees the loaded faces' particle discretisation (1.3 % at 6^3, as in
    // the uniaxial test): it gets the finer cloud.
    const int n = grid ? 12 : 6;
    const core::ParticleCloud cloud =
        dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(n, n, n));
    dm::DemConfig config;
    config.network.width = 16;
    config.network.depth = 2;
    config.adam.iterations = grid ? 0 : 300;
    config.grid.cell = grid ? 0.34 : 0.0;
    config.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;
    config.grid.body_cells = 0.0;  // without grid_cell: the MLP alone
    config.threads = 1;
    dm::DemSolver dem(cloud, s, config);
    const dm::DemReport r = dem.solve();
    const auto u = dem.predict(cloud.positions);
    double err = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i)
      err = std::max(err, (u[i] - Vector3d(gamma * cloud.positions[i].y(), 0, 0)).norm());
    std::cout << "simple shear, DEM " << (grid ? "grid Newton" : "MLP Adam 300") << ": max error / gamma "
              << err / gamma << " in " << r.seconds << " s\n";
    EXPECT_LT(err / gamma, 0.01) << (grid ? "grid" : "MLP");
  }
}

TEST(DemGrid, SolveControlStopsReportsAndKeepsTheLastGoodState) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(8, 8, 8));
  const core::Scenario s = dm::uniaxialTractionScenario(2e5);
  dm::DemConfig config;
  config.grid.cell = 0.25;
  config.threads = 1;
  // Progress reaches the sink with the fields filled; the answer is a checked equilibrium.
  {
    dm::DemSolver dem(cloud, s, config);
    std::vector<dm::SolveProgress> reports;
    dm::SolveControl control;
    control.progress_interval = 0.0;
    control.progress = [&](const dm::SolveProgress& p) { reports.push_back(p); };
    dem.setControl(control);
    const dm::DemReport r = dem.solve();
    ASSERT_FALSE(reports.empty());
    EXPECT_EQ(reports.back().solver, "dem");
    EXPECT_EQ(reports.back().phase, "newton");
    EXPECT_GT(reports.back().load_fraction, 0.0);
    EXPECT_LE(r.residual, 1e-6);
    EXPECT_LT(r.energy, 0.0);
  }
  // A cancel flag set before the first iteration stops the solve with its cause, and the solver
  // keeps the undeformed state it started from.
  {
    dm::DemSolver dem(cloud, s, config);
    std::atomic<bool> cancel{true};
    dm::SolveControl control;
    control.cancel = &cancel;
    dem.setControl(control);
    try {
      dem.solve();
      ADD_FAILURE() << "a cancelled solve returned";
    } catch (const dm::SolveError& e) {
      EXPECT_EQ(e.failure(), dm::SolveFailure::kCancelled) << e.what();
      EXPECT_NE(std::string(e.what()).find("load fraction 0"), std::string::npos) << e.what();
    }
    for (const Vector3d& u : dem.predict(cloud.positions)) EXPECT_LT(u.norm(), 1e-12);
  }
  // A spent budget says so.
  {
    dm::DemSolver dem(cloud, s, config);
    dm::SolveControl control;
    control.time_limit = 1e-9;
    dem.setControl(control);
    try {
      dem.solve();
      ADD_FAILURE() << "a solve past its time limit returned";
    } catch (const dm::SolveError& e) {
      EXPECT_EQ(e.failure(), dm::SolveFailure::kTimeLimit) << e.what();
    }
  }
}

TEST(DemGrid, ParticlesTooCoarseForTheBodysGridSayTheAnswerWillBeStiff) {
  // The grid is never finer than 0.6 particle spacings. Two particles across the 60 mm bar floor
  // its cells at 18 mm, three across its 53 mm mean thickness (4V/A): a stiff answer, said so.
  // Six particles across leave the body's own 8.9 mm cells, six across its thickness: nothing to say.
  const core::Scenario twist = twistedBar(0.5);
  const auto solveOn = [&](int across) {
    const core::ParticleCloud bar = dm::makeBoxParticles(Vector3d(-0.03, -0.03, 0), Vector3d(0.03, 0.03, 0.24),
                                                         Eigen::Vector3i(across, across, 4 * across));
    dm::DemSolver dem(bar, twist, dm::DemConfig{});
    return dem.solve();
  };
  const dm::DemReport coarse = solveOn(2);
  EXPECT_NE(coarse.coarse_grid.find("cells across the body's mean thickness"), std::string::npos) << coarse.coarse_grid;
  EXPECT_NE(coarse.coarse_grid.find("stiff"), std::string::npos) << coarse.coarse_grid;
  const dm::DemReport fine = solveOn(6);
  EXPECT_EQ(fine.coarse_grid, "");
}
