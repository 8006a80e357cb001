#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <unistd.h>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/reference_problems.hpp"

#include "box_region.hpp"
#include "parametric_mlp.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

using demnerf::mechanics::test::box;

core::Fixture roller(int axis) {
  core::Fixture f;
  f.name = std::string("roller_") + "xyz"[axis];
  Vector3d c(0.5, 0.5, 0.5), s(2, 2, 2);
  c(axis) = 0.0;
  s(axis) = 1e-6;
  f.region = box(c, s);
  f.constrained = Eigen::Vector3i::Zero();
  f.constrained(axis) = 1;
  return f;
}

core::Scenario uniaxial(double p11) { return dm::uniaxialTractionScenario(p11); }

double relativeError(const dm::DemSolver& dem, const core::ParticleCloud& cloud, double a, double b,
                     double load_scale = 1.0) {
  const auto u = dem.predict(cloud.positions, load_scale);
  double err = 0, ref = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& X = cloud.positions[i];
    const Vector3d exact((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err = std::max(err, (u[i] - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  return err / ref;
}

TEST(Dem, UniaxialTractionMatchesTheClosedFormWithExactBoundaries) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  dm::DemConfig config;
  config.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  config.network.width = 16;
  config.network.depth = 2;
  config.adam.iterations = 1000;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  const double error = relativeError(dem, cloud, a, b);
  std::cout << "DEM exact BCs: max rel error " << error << ", " << r.iterations << " iterations, " << r.seconds << " s\n";
  // Max-norm error; measured 1.1-1.5 % over seeds 1-3 (rel. L2 0.5-0.6 %).
  // The rigid-translation exploit gives 1000 % and more; a surface strain layer 5-10 %.
  EXPECT_LT(error, 0.03);
  EXPECT_GT(r.min_J, 0.0);
  // The result field has one row per particle, in order, with the homogeneous von Mises stress.
  const core::ResultField field = dem.result();
  ASSERT_EQ(field.size(), cloud.size());
  EXPECT_NEAR(field.von_mises[0], 2e5 / (b * b), 0.1 * 2e5);
}

TEST(Dem, OutputLayerNewtonAloneSolvesTheUniaxialStretch) {
  // No Adam at all: Newton on the output layer of the random initial network (a Ritz solve in
  // the network's basis). The homogeneous answer lies in the span of any basis with a constant.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  dm::DemConfig config;
  config.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  config.network.width = 16;
  config.network.depth = 2;
  config.adam.iterations = 0;
  config.output_newton.enabled = true;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  const double error = relativeError(dem, cloud, a, b);
  std::cout << "DEM output-layer Newton: max rel error " << error << ", " << r.seconds << " s\n";
  // Measured 1.2 % (rel. L2 0.5 %) in 0.01 s; without the Newton solve the zero output layer
  // leaves u = 0 (100 %).
  EXPECT_LT(error, 0.03);
  EXPECT_GT(r.min_J, 0.0);
}

TEST(Dem, ParametricModeAnswersEveryLoadInItsRangeWithoutRetraining) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  dm::DemConfig config = dm::test::parametricMlp(16, 600, 1.0);
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  const auto material = dm::makeMaterial(s.material);
  double worst = 0.0;
  for (const double scale : {0.25, 0.5, 0.8, 1.0}) {
    double b = 0;
    const double a = dm::uniaxialStretchForStress(*material, scale * 2e5, &b);
    const double error = relativeError(dem, cloud, a, b, scale);
    std::cout << "DEM parametric: load x" << scale << " max rel error " << error << "\n";
    worst = std::max(worst, error);
  }
  std::cout << "DEM parametric training " << r.seconds << " s\n";
  // One training covers the range; separately solved loads are exact (closed form) here.
  EXPECT_LT(worst, 0.05);
  // The rest state at load 0 holds exactly (u = s (g + D z)); outside the range is refused.
  for (const auto& u : dem.predict(cloud.positions, 0.0)) EXPECT_EQ(u.norm(), 0.0);
  EXPECT_THROW(dem.predict(cloud.positions, 1.5), core::Error);
  // A non-parametric network refuses other loads instead of answering wrongly.
  config.parametric.enabled = false;
  config.adam.iterations = 10;
  dm::DemSolver plain(cloud, s, config);
  EXPECT_THROW(plain.solve(), dm::SolveError);  // 10 steps are no equilibrium; the field is kept
  EXPECT_THROW(plain.predict(cloud.positions, 0.5), core::Error);
  config.parametric.enabled = true;
  config.parametric.load_range_min = 0.2;
  config.parametric.load_range_max = 0.8;  // does not contain the scenario's own load
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
}

TEST(Dem, UniaxialTractionWithThePenaltyFormulation) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  dm::DemConfig config;
  config.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  config.network.width = 16;
  config.network.depth = 2;
  config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  config.adam.iterations = 1000;
  config.threads = 1;
  dm::DemSolver dem(cloud, s, config);
  // The penalty formulation is the paper's baseline, not the product's: 1000 steps leave it 10 %
  // off (max error; 10-18 % over seeds 1-3), which the equilibrium check refuses: the weak form
  // asks for a correction of ~5 % of the displacement.
  try {
    dem.solve();
    ADD_FAILURE() << "the penalty answer 10 % off passed the equilibrium check";
  } catch (const dm::SolveError& e) {
    EXPECT_EQ(e.failure(), dm::SolveFailure::kNotConverged) << e.what();
    EXPECT_NE(std::string(e.what()).find("Newton correction"), std::string::npos) << e.what();
  }
  // The refused field stays for inspection (the answer of the last load step), as close as before.
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  const double error = relativeError(dem, cloud, a, b);
  std::cout << "DEM penalty BCs: max rel error " << error << "\n";
  EXPECT_LT(error, 0.2);
}

TEST(Dem, AnalyticLiftGradientsMatchFiniteDifferences) {
  // Two fixtures on one component (transfinite blend) and a sphere, away from the distance kinks.
  core::Scenario s = uniaxial(1e5);
  core::Fixture f = roller(0);
  f.region = box(Vector3d(1.0, 0.5, 0.5), Vector3d(1e-6, 2, 2));
  f.displacement = Vector3d(0.3, 0, 0);
  s.fixtures.push_back(f);
  core::Fixture ball;
  ball.region.type = core::Region::Type::kSphere;
  ball.region.center = Vector3d(0.5, 0.5, 2.0);
  ball.region.radius = 0.4;
  ball.displacement = Vector3d(0.1, -0.2, 0.05);
  s.fixtures.push_back(ball);
  const Vector3d x(0.37, 0.61, 0.44);
  Vector3d g, D;
  Eigen::Matrix3d gg, gD;
  dm::dirichletLiftAt(s, x, 1.3, g, gg, D, gD);
  EXPECT_GT(gD.norm(), 0.1);
  EXPECT_GT(gg.norm(), 0.01);
  for (int k = 0; k < 3; ++k) {
    Vector3d xp = x, xm = x, gp, gm, Dp, Dm;
    Eigen::Matrix3d unused1, unused2;
    xp(k) += 1e-6;
    xm(k) -= 1e-6;
    dm::dirichletLiftAt(s, xp, 1.3, gp, unused1, Dp, unused2);
    dm::dirichletLiftAt(s, xm, 1.3, gm, unused1, Dm, unused2);
    EXPECT_LT(((gp - gm) / 2e-6 - gg.col(k)).norm(), 1e-6) << "column " << k;
    EXPECT_LT(((Dp - Dm) / 2e-6 - gD.col(k)).norm(), 1e-6) << "column " << k;
  }
}

TEST(Dem, BadInputFailsBeforeTraining) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  core::Scenario s = uniaxial(1e5);
  s.fixtures.clear();
  EXPECT_THROW(dm::DemSolver(cloud, s), core::Error);
  s = uniaxial(1e5);
  s.loads[0].region.center = Vector3d(4, 4, 4);
  EXPECT_THROW(dm::DemSolver(cloud, s), core::Error);
  s = uniaxial(1e5);
  s.material.poisson_ratio = 0.5;
  EXPECT_THROW(dm::DemSolver(cloud, s), core::Error);
  s = uniaxial(1e5);
  dm::DemConfig config;
  config.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  config.network.activation = "relu6";
  EXPECT_THROW(dm::DemSolver(cloud, s, config), core::Error);
}

TEST(Dem, CrushingLoadIsReportedNotReturned) {
  // A compressive load the body cannot carry in one go: det F <= 0 must surface as an error.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  core::Scenario s = uniaxial(-5e7);
  dm::DemConfig config;
  config.grid.body_cells = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  config.network.width = 8;
  config.network.depth = 1;
  config.adam.iterations = 50;
  config.threads = 1;
  config.max_halvings = 1;
  dm::DemSolver dem(cloud, s, config);
  EXPECT_THROW(dem.solve(), core::Error);
}

// The MLP alone trained by Adam with the paper's penalty boundary (the earlier `--method mlp`),
// made fast: a narrower network and few steps, no L-BFGS.
dm::DemConfig smallPaperDem(int adam_iterations) {
  dm::DemConfig config = dm::paperDemConfig();
  config.network.width = 16;
  config.network.depth = 2;
  config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  config.lbfgs.iterations = 0;
  config.load_steps = 0;
  config.adam.iterations = adam_iterations;
  config.threads = 1;
  return config;
}

TEST(Dem, MlpThatCannotConvergeSaysWhyAndNeverReportsSuccess) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  // Far too few Adam steps: the equilibrium check refuses the answer, naming the residual and
  // what to change.
  {
    dm::DemSolver dem(cloud, s, smallPaperDem(5));
    try {
      dem.solve();
      ADD_FAILURE() << "5 Adam steps reported an equilibrium";
    } catch (const dm::SolveError& e) {
      EXPECT_EQ(e.failure(), dm::SolveFailure::kNotConverged) << e.what();
      EXPECT_NE(std::string(e.what()).find("residual"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("adam.iterations"), std::string::npos) << e.what();
    }
  }
  // A schedule of minutes against a 0.5 s budget: it stops at the limit with the cause, reports
  // progress while it runs, and keeps the last good state (the undeformed one: nothing converged).
  dm::DemSolver dem(cloud, s, smallPaperDem(1000000));
  std::vector<dm::SolveProgress> reports;
  dm::SolveControl control;
  control.time_limit = 0.5;
  control.progress_interval = 0.1;
  control.progress = [&](const dm::SolveProgress& p) { reports.push_back(p); };
  dem.setControl(control);
  const auto start = std::chrono::steady_clock::now();
  try {
    dem.solve();
    ADD_FAILURE() << "a solve past its time limit returned";
  } catch (const dm::SolveError& e) {
    EXPECT_EQ(e.failure(), dm::SolveFailure::kTimeLimit) << e.what();
    EXPECT_NE(std::string(e.what()).find("Adam steps"), std::string::npos) << e.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  ASSERT_FALSE(reports.empty());
  EXPECT_EQ(reports.back().phase, "adam");
  EXPECT_GT(reports.back().iteration, 0);
  for (const Vector3d& u : dem.predict(cloud.positions)) EXPECT_EQ(u.norm(), 0.0);
}

TEST(Dem, WellResolvedMlpPassesTheEquilibriumCheck) {
  // 512 particles in uniaxial traction, solved by the output-layer Newton (a Ritz solve in the
  // network's basis, which holds the homogeneous answer): a converged answer the check passes.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(8, 8, 8));
  const core::Scenario s = uniaxial(2e5);
  dm::DemConfig config = smallPaperDem(0);
  config.boundary.kind = dm::DemConfig::Boundary::kExact;
  config.output_newton.enabled = true;
  dm::DemSolver dem(cloud, s, config);
  const dm::DemReport r = dem.solve();
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  std::cout << "MLP alone, 8^3 cube: residual " << r.residual << ", max rel error " << relativeError(dem, cloud, a, b)
            << ", " << r.seconds << " s\n";
  EXPECT_TRUE(std::isfinite(r.residual));
  EXPECT_LT(r.residual, 0.1);
  EXPECT_LT(relativeError(dem, cloud, a, b), 0.03);
}

}  // namespace

TEST(Dem, SavedModelsPredictExactlyAsBeforeAndDamageIsReported) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(4, 4, 4));
  const dm::DemConfig config = dm::test::parametricMlp(8, 50, 1.5);
  dm::DemSolver dem(cloud, uniaxial(1e5), config);
  // 50 steps are no equilibrium: a parametric training is kept but said unverified (its answers
  // are used by dem_node's instant path), and saving and loading must reproduce it all the same.
  const dm::DemReport report = dem.solve();
  EXPECT_NE(report.unverified.find("not an equilibrium"), std::string::npos) << report.unverified;
  const std::string path = ::testing::TempDir() + "dem_model_" + std::to_string(::getpid()) + ".dem";
  dm::saveDemModel(dem, path);
  const dm::DemSolver loaded = dm::loadDemModel(path);
  const std::vector<Vector3d> points = {Vector3d(0.2, 0.3, 0.4), Vector3d(0.9, 0.1, 0.5)};
  for (const double scale : {0.5, 1.0, 1.4}) {
    const auto a = dem.predict(points, scale), b = loaded.predict(points, scale);
    for (std::size_t i = 0; i < points.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), 1e-12 + 1e-6 * a[i].norm());
  }
  EXPECT_THROW(loaded.predict(points, 2.0), core::Error);  // the range travelled with the model

  // One flipped byte, a truncation and a missing file each give an error naming the file.
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto expectError = [&](const std::string& content, const std::string& fragment) {
    const std::string bad = path + ".bad";
    std::ofstream(bad, std::ios::binary) << content;
    try {
      dm::loadDemModel(bad);
      ADD_FAILURE() << "no error for " << fragment;
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
    std::remove(bad.c_str());
  };
  std::string flipped = bytes;
  flipped[flipped.size() / 2] ^= 0x40;
  expectError(flipped, "checksum");
  expectError(bytes.substr(0, bytes.size() / 3), "DEM model");
  expectError("not a model at all", "magic");
  EXPECT_THROW(dm::loadDemModel(path + ".missing"), core::Error);
  std::remove(path.c_str());
}
