// Instant answers for any wrench on a known patch (issue 17, item 2): PatchResponse's one-time
// preparation on the T-bar (config/scenarios/tbar_twist.yaml's material and base clamp, the
// wrench on its front_right patch), then random wrenches in the range answered by the basis and
// by a full DEM solve from scratch (the reference): time per answer and rel. L2 against it.
// Usage: mechanics_patch_response [cell=0.015] [force=0.5] [torque=0.02] [wrenches=8] [seed=1]
//        [cross=1] [scenario=config/scenarios/tbar_twist.yaml]

#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/compare_results.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/patch_response.hpp"
#include "mechanics_bench_common.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;
using demnerf::bench::relativeL2;

namespace {

double maxNorm(const std::vector<Vector3d>& u) {
  double m = 0.0;
  for (const auto& v : u) m = std::max(m, v.norm());
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  auto args = demnerf::bench::keyValueArguments(argc, argv);
  auto number = [&](const std::string& key, double fallback) { return args.count(key) ? std::stod(args[key]) : fallback; };
  const double h = number("cell", 0.015), force_range = number("force", 0.5), torque_range = number("torque", 0.02);
  const int wrenches = static_cast<int>(number("wrenches", 8));
  const std::string scenario_path =
      args.count("scenario") ? args["scenario"] : std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml";
  core::Scenario base = core::loadScenario(scenario_path);
  const core::Region patch = base.loads.front().region;
  const core::ParticleCloud cloud = demnerf::bench::tbarParticles(h);
  const dm::DemConfig dem;  // the product's DEM: feature grid, Newton
  dm::PatchResponseConfig config;
  config.force_range = force_range;
  config.torque_range = torque_range;
  config.cross_terms = number("cross", 1.0) != 0.0;
  dm::PatchResponse response(cloud, base, patch, dem, config);
  response.prepare();
  std::printf("T-bar, %zu particles (cell %.4f m), patch %s\n", cloud.size(), h, patch.describe().c_str());
  std::printf("range: |F_i| <= %.3g N, |T_i| <= %.3g N m; preparation (%d DEM solves%s) %.2f s\n\n", force_range,
              torque_range, response.preparationSolves(), config.cross_terms ? ", cross terms" : "",
              response.preparationSeconds());
  std::printf("| wrench | F (N) | T (N m) | max |u| (mm) | basis (ms) | full solve (s) | rel. L2 |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- |\n");
  std::mt19937 random(static_cast<unsigned>(number("seed", 1)));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> basis_ms, errors, full_seconds;
  for (int n = 0; n < wrenches; ++n) {
    const Vector3d force = force_range * Vector3d(unit(random), unit(random), unit(random));
    const Vector3d torque = torque_range * Vector3d(unit(random), unit(random), unit(random));
    const dm::PatchAnswer fast = response.answer(force, torque);
    const auto start = std::chrono::steady_clock::now();
    dm::DemSolver full(cloud, response.scenarioFor(force, torque), dem);
    full.solve();
    const std::vector<Vector3d> reference = full.result().displacements;
    full_seconds.push_back(demnerf::bench::since(start));
    basis_ms.push_back(1000.0 * fast.seconds);
    errors.push_back(relativeL2(fast.field.displacements, reference));
    std::printf("| %d (%s) | (%.2f, %.2f, %.2f) | (%.3f, %.3f, %.3f) | %.2f | %.3f | %.2f | %.2f %% |\n", n,
                fast.path.c_str(), force.x(), force.y(), force.z(), torque.x(), torque.y(), torque.z(),
                1000.0 * maxNorm(reference), basis_ms.back(), full_seconds.back(), 100.0 * errors.back());
  }
  double worst = 0.0;
  for (double e : errors) worst = std::max(worst, e);
  std::printf("\nbasis answer: median %.3f ms; full solve median %.2f s; rel. L2 median %.2f %%, worst %.2f %%\n",
              demnerf::bench::median(basis_ms), demnerf::bench::median(full_seconds),
              100.0 * demnerf::bench::median(errors), 100.0 * worst);
  // Outside the range: the full path, warm-started.
  const dm::PatchAnswer outside = response.answer(Vector3d(3.0 * force_range, 0, 0), Vector3d::Zero());
  std::printf("outside the range (F = %.2f N along x): path %s, %.2f s\n", 3.0 * force_range, outside.path.c_str(),
              outside.seconds);
  return 0;
}
