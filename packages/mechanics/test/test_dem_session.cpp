#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/core/wrench_load.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/dem_session.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "parametric_mlp.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {

double maxRelativeError(const core::ResultField& field, double p11) {
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(dm::uniaxialTractionScenario(p11).material), p11, &b);
  double err = 0, ref = 0;
  for (std::size_t i = 0; i < field.size(); ++i) {
    const Vector3d& X = field.positions[i];
    const Vector3d exact((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    err = std::max(err, (field.displacements[i] - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  return err / ref;
}

// The rostests' cantilever (100 x 20 x 20 mm, E = 100 kPa, clamped at x = 0) with `force` on the
// particles within 15 mm of its free end's centre, as dem_node turns a wrench there into a load.
core::Scenario tipLoadedBar(const Vector3d& force) {
  core::Scenario s;
  s.name = "tip_loaded_bar";
  s.material.youngs_modulus = 1e5;
  core::Fixture clamp;
  clamp.name = "clamp";
  clamp.region.type = core::Region::Type::kBox;
  clamp.region.size = Vector3d(0.01, 0.2, 0.2);
  s.fixtures.push_back(clamp);
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Vector3d(0.1, 0, 0);
  s.loads.push_back(core::loadFromWrench(tool, force, Vector3d::Zero(), 0.015, "wrench"));
  return s;
}

}  // namespace

TEST(DemSession, LoadScaleIsFoundOnlyForAPureScaling) {
  const core::Scenario reference = dm::uniaxialTractionScenario(2e5);
  EXPECT_NEAR(*dm::loadScaleBetween(reference, dm::uniaxialTractionScenario(5e4)), 0.25, 1e-12);
  core::Scenario moved = dm::uniaxialTractionScenario(2e5);
  moved.loads[0].region.center.y() += 0.1;  // another patch
  EXPECT_FALSE(dm::loadScaleBetween(reference, moved));
  core::Scenario turned = dm::uniaxialTractionScenario(2e5);
  turned.loads[0].force.y() = 1e4;  // not parallel to the trained force
  EXPECT_FALSE(dm::loadScaleBetween(reference, turned));
  core::Scenario stiffer = dm::uniaxialTractionScenario(2e5);
  stiffer.material.youngs_modulus *= 2;
  EXPECT_FALSE(dm::loadScaleBetween(reference, stiffer));
}

TEST(DemSession, ScaledLoadsAreAnsweredInstantlyOthersTrainedAgain) {
  const dm::DemConfig config = dm::test::parametricMlp(16, 300, 1.5);
  dm::DemSession session(config);
  EXPECT_THROW(session.answer(dm::uniaxialTractionScenario(2e5)), core::Error);  // no particles yet
  session.setParticles(dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6)));

  const dm::DemSessionAnswer first = session.answer(dm::uniaxialTractionScenario(2e5));
  EXPECT_EQ(first.mode, "cold");
  EXPECT_LT(maxRelativeError(first.outcome.field, 2e5), 0.05);

  const dm::DemSessionAnswer half = session.answer(dm::uniaxialTractionScenario(1e5));
  EXPECT_EQ(half.mode, "instant");
  EXPECT_NEAR(half.load_scale, 0.5, 1e-12);
  EXPECT_LT(maxRelativeError(half.outcome.field, 1e5), 0.05);
  std::cout << "cold " << first.outcome.seconds << " s, instant " << half.outcome.seconds << " s\n";
  EXPECT_LT(half.outcome.seconds, 0.1 * first.outcome.seconds);

  // Outside the trained range (3.2e5 > 1.5 x 2e5): trained again, warm-started.
  const dm::DemSessionAnswer beyond = session.answer(dm::uniaxialTractionScenario(3.2e5));
  EXPECT_EQ(beyond.mode, "warm");
  EXPECT_LT(maxRelativeError(beyond.outcome.field, 3.2e5), 0.05);

  // Reversed (s = -0.5): the trained tension field is no start for a compression; a new network.
  const dm::DemSessionAnswer reversed = session.answer(dm::uniaxialTractionScenario(-1e5));
  EXPECT_EQ(reversed.mode, "cold");
  EXPECT_LT(maxRelativeError(reversed.outcome.field, -1e5), 0.05);
  // Its own scalings are answered at once again.
  EXPECT_EQ(session.answer(dm::uniaxialTractionScenario(-5e4)).mode, "instant");
}

// The MLP alone, trained for a downward tip force, then asked for a sideways one: on the
// development machine its warm start ends in no equilibrium ("exploited its Gauss points") and
// the session solves again on a new network. Training is CPU-dependent, so where the warm start
// passes the answer must still be an equilibrium of the same energy and say it was warm.
TEST(DemSession, AWarmStartThatFailsItsCheckIsSolvedAgainOnANewNetwork) {
  dm::DemConfig config = dm::paperDemConfig();
  config.threads = 1;
  const core::ParticleCloud bar =
      dm::makeBoxParticles(Vector3d(0, -0.01, -0.01), Vector3d(0.1, 0.01, 0.01), Eigen::Vector3i(10, 2, 2));
  dm::DemSession fresh(config);
  fresh.setParticles(bar);
  const dm::DemSessionAnswer sideways = fresh.answer(tipLoadedBar(Vector3d(0, -0.02, 0)));
  ASSERT_LT(sideways.outcome.energy, 0.0);

  dm::DemSession session(config);
  session.setParticles(bar);
  EXPECT_EQ(session.answer(tipLoadedBar(Vector3d(0, 0, -0.02))).mode, "cold");
  const dm::DemSessionAnswer turned = session.answer(tipLoadedBar(Vector3d(0, -0.02, 0)));
  std::cout << "turned: " << turned.mode << (turned.warm_failure.empty() ? "" : " after the warm start failed: ")
            << turned.warm_failure.substr(0, 120) << "\n";
  EXPECT_EQ(turned.mode == "cold", !turned.warm_failure.empty());
  EXPECT_NEAR(turned.outcome.energy, sideways.outcome.energy, 0.05 * std::abs(sideways.outcome.energy));
}
