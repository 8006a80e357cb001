#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <iostream>
#include <limits>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/pinn_solver.hpp"
#include "demnerf/mechanics/reference_problems.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

// Unit cube on rollers pulled by a uniform traction P11 on x = 1: a homogeneous closed form.
core::Scenario uniaxial(double p11, const std::string& model = "neo_hookean") {
  return dm::uniaxialTractionScenario(p11, model);
}

TEST(Pinn, UniaxialTractionMatchesTheClosedForm) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario s = uniaxial(2e5);
  dm::PinnConfig config;
  config.width = 16;
  config.depth = 2;
  config.adam_iterations = 300;
  config.lbfgs_iterations = 200;  // Adam alone: 2-3.5 % after 600 iterations; with L-BFGS 0.2 %
  config.threads = 1;
  dm::PinnSolver pinn(cloud, s, config);
  const dm::PinnReport r = pinn.solve();
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  const auto u = pinn.predict(cloud.positions);
  double err2 = 0, ref2 = 0, err_max = 0, ref_max = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& X = cloud.positions[i];
    const Vector3d exact((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err2 += (u[i] - exact).squaredNorm();
    ref2 += exact.squaredNorm();
    err_max = std::max(err_max, (u[i] - exact).norm());
    ref_max = std::max(ref_max, exact.norm());
  }
  const double rel_l2 = std::sqrt(err2 / ref2), rel_max = err_max / ref_max;
  std::cout << "PINN uniaxial: rel L2 " << rel_l2 << ", max " << rel_max << ", loss " << r.loss << " (R "
            << r.residual_mse << ", t " << r.traction_mse << ", u " << r.displacement_mse << "), " << r.iterations
            << " iterations, " << r.seconds << " s\n";
  // Stretch a - 1 = 0.19 and lateral b - 1 = -0.05: the rest state (u = 0) is 100 % off, a
  // missed Poisson contraction ~25 %.
  // Measured rel. L2 0.18-0.26 %, max 0.2-0.5 % (seeds 1-3, bench/mechanics_pinn).
  EXPECT_LT(rel_l2, 0.02);
  EXPECT_LT(rel_max, 0.04);
  EXPECT_GT(r.min_J, 0.0);
  EXPECT_TRUE(std::isfinite(r.energy));
  const core::ResultField field = pinn.result();
  ASSERT_EQ(field.size(), cloud.size());
  EXPECT_NEAR(field.von_mises[0], 2e5 / (b * b), 0.1 * 2e5);
}

TEST(Pinn, ForwardModeDivergenceAgreesWithAutograd) {
  // A briefly trained network is far from homogeneous, so every Hessian term contributes; both
  // materials' closed-form directional derivatives are checked.
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  for (const std::string model : {"neo_hookean", "neo_hookean_decoupled"}) {
    dm::PinnConfig config;
    config.width = 8;
    config.depth = 2;
    config.adam_iterations = 30;
    config.lbfgs_iterations = 0;
    config.threads = 1;
    config.double_precision = true;
    dm::PinnSolver pinn(cloud, uniaxial(3e5, model), config);
    pinn.solve();
    EXPECT_LT(pinn.divergenceSelfCheck(), 1e-9) << model;
  }
}

TEST(Pinn, BadInputFailsBeforeTraining) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  const core::Scenario s = uniaxial(1e5);
  dm::PinnConfig config;
  config.weight_traction = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(dm::PinnSolver(cloud, s, config), core::Error);
  config = {};
  config.weight_displacement = -1.0;
  EXPECT_THROW(dm::PinnSolver(cloud, s, config), core::Error);
  config = {};
  config.activation = "relu";  // second derivative zero almost everywhere: the residual is blind
  EXPECT_THROW(dm::PinnSolver(cloud, s, config), core::Error);
  config = {};
  config.adam_learning_rate = std::numeric_limits<double>::infinity();
  EXPECT_THROW(dm::PinnSolver(cloud, s, config), core::Error);
  core::Scenario no_fixture = s;
  no_fixture.fixtures.clear();
  EXPECT_THROW(dm::PinnSolver(cloud, no_fixture), core::Error);
  core::Scenario stray_load = s;
  stray_load.loads[0].region.center = Vector3d(4, 4, 4);
  EXPECT_THROW(dm::PinnSolver(cloud, stray_load), core::Error);
  // A valid problem constructs without training (the network starts at rest).
  dm::PinnSolver idle(cloud, s);
  for (const auto& u : idle.predict(cloud.positions)) EXPECT_EQ(u.norm(), 0.0);
}

TEST(Pinn, SolveControlStopsAndReports) {
  const core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(3, 3, 3));
  const core::Scenario s = uniaxial(1e5);
  dm::PinnConfig config;
  config.width = 8;
  config.depth = 1;
  config.adam_iterations = 20;
  config.lbfgs_iterations = 5;
  config.threads = 1;
  auto cause = [&](const dm::SolveControl& control) {
    dm::PinnSolver pinn(cloud, s, config);
    try {
      pinn.solve(control);
    } catch (const dm::SolveError& e) {
      // Stopped inside the first load step: the network is back at rest, not half-trained.
      for (const auto& u : pinn.predict(cloud.positions)) EXPECT_EQ(u.norm(), 0.0);
      return std::string(dm::solveFailureName(e.failure()));
    }
    return std::string("converged");
  };
  std::atomic<bool> cancel{true};
  dm::SolveControl cancelled;
  cancelled.cancel = &cancel;
  EXPECT_EQ(cause(cancelled), "cancelled");
  dm::SolveControl hurried;
  hurried.time_limit = 1e-9;
  EXPECT_EQ(cause(hurried), "time_limit");
  // Reports come at most once a second after the first, which comes at the first iteration.
  std::vector<dm::SolveProgress> seen;
  dm::SolveControl watched;
  watched.progress_interval = 0.0;
  watched.progress = [&](const dm::SolveProgress& p) { seen.push_back(p); };
  EXPECT_EQ(cause(watched), "converged");
  ASSERT_FALSE(seen.empty());
  for (const auto& p : seen) {
    EXPECT_EQ(p.solver, "pinn");
    EXPECT_TRUE(p.phase == "adam" || p.phase == "lbfgs") << p.phase;
    EXPECT_GT(p.load_fraction, 0.0);
    EXPECT_TRUE(std::isfinite(p.energy));
  }
}

}  // namespace
