// The paper's DEM (the MLP alone, `--method mlp`, paperDemConfig()) on one scenario of the solver
// matrix and one cloud from the product's samplers, with its convergence curve: every `every`
// optimiser iterations the answer is read (tip or probe displacement, rel. L2 against the matrix's
// cached reference FEM) with the wall and CPU seconds spent so far (the reading itself excluded),
// then the solve's own verdict (its equilibrium check passes or refuses it).
//
// Usage: mechanics_mlp key=value ...
//   scenario=beam3d (a name of mechanics_matrix's scenarios)  sampler=grid|poisson|random  div=6
//   seed=1 (the sampler's)  config=FILE (solver settings over paperDemConfig(), as --config)
//   boundary=penalty|exact (over both)  ref=DIR (a mechanics_matrix out= dir whose
//   reference_<scenario>_exact_fine.ply holds these particles; none: no rel. L2)
//   source=exact|nerf (nerf: the surface mechanics_matrix cached in REF/nerf_<scene>/, and its
//   reference_<scenario>_nerf_fine.ply)
//   every=25 (iterations between readings; 0: none)  time_limit=60  verbose=0|1
//   bands=z1,z2,... (the final error's share and rel. L2 in each band of z)
//   energy=0|1 (1: the training energy on its Gauss points once a second)
// Prints one line per reading and a summary line.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
namespace geo = demnerf::geometry;
namespace bench = demnerf::bench;
using Eigen::Vector3d;

namespace {

using Arguments = std::map<std::string, std::string>;

std::string text(const Arguments& a, const char* key, const std::string& fallback) {
  const auto it = a.find(key);
  return it != a.end() ? it->second : fallback;
}

// The reference displacement at each particle, read from a matrix reference on a union of clouds
// that holds these particles (matched by their float positions, as the result PLY stores them).
std::vector<Vector3d> referenceAt(const std::string& path, const core::ParticleCloud& cloud) {
  if (path.empty() || !std::filesystem::exists(path)) return {};
  const core::ResultField field = core::readResult(path);
  std::map<std::tuple<float, float, float>, std::size_t> at;
  for (std::size_t i = 0; i < field.size(); ++i) {
    const Vector3d& p = field.positions[i];
    at.emplace(std::make_tuple(float(p.x()), float(p.y()), float(p.z())), i);
  }
  std::vector<Vector3d> u;
  for (const Vector3d& p : cloud.positions) {
    const auto it = at.find(std::make_tuple(float(p.x()), float(p.y()), float(p.z())));
    if (it == at.end()) {
      std::fprintf(stderr, "%s does not hold these particles: no rel. L2\n", path.c_str());
      return {};
    }
    u.push_back(field.displacements[it->second]);
  }
  return u;
}

struct Reading {
  double tip = 0.0, rel_l2 = std::nan("");
};

Reading read(const dm::DemSolver& dem, const core::ParticleCloud& cloud, const bench::MatrixCase& mc,
             const std::vector<Vector3d>& reference) {
  Reading r;
  const bool beam = mc.name == "beam3d";
  const std::vector<Vector3d> at = dem.predict({beam ? Vector3d(4, 0.5, 0.5) : mc.probes.front().point});
  r.tip = beam ? at[0].y() : at[0].norm();
  if (!reference.empty()) r.rel_l2 = bench::relativeL2(dem.predict(cloud.positions), reference);
  return r;
}

// Where the error lies: each band of the body along z (bands=z0,z1,...), its share of the squared
// error and its own rel. L2 (the T-bar: the clamp's band, the leg, the bar).
void printBands(const std::string& cuts, const std::vector<Vector3d>& x, const std::vector<Vector3d>& u,
                const std::vector<Vector3d>& reference) {
  std::vector<double> z{-1e9};
  for (std::size_t at = 0; at < cuts.size();) {
    const std::size_t comma = std::min(cuts.find(',', at), cuts.size());
    z.push_back(std::stod(cuts.substr(at, comma - at)));
    at = comma + 1;
  }
  z.push_back(1e9);
  std::vector<double> e(z.size(), 0.0), r(z.size(), 0.0);
  double total = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const std::size_t b = std::upper_bound(z.begin(), z.end(), x[i].z()) - z.begin() - 1;
    e[b] += (u[i] - reference[i]).squaredNorm(), r[b] += reference[i].squaredNorm();
    total += (u[i] - reference[i]).squaredNorm();
  }
  for (std::size_t b = 0; b + 1 < z.size(); ++b)
    std::printf("  band z in [%g, %g): %.1f %% of the squared error, rel. L2 %.2f %%\n", z[b], z[b + 1], 100 * e[b] / total,
                100 * std::sqrt(e[b] / std::max(r[b], 1e-300)));
}

dm::DemConfig configFrom(const Arguments& a) {
  dm::DemConfig config = dm::solverDefaults("mlp", text(a, "config", "")).dem;
  const std::string boundary = text(a, "boundary", "");
  if (boundary == "penalty") config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  if (boundary == "exact") config.boundary.kind = dm::DemConfig::Boundary::kExact;
  config.verbose = text(a, "verbose", "0") != "0";
  return config;
}

}  // namespace

int main(int argc, char** argv) {
  dm::keepLargeAllocationsInHeap();    // as the product's entry points do (tune_allocator)
  dm::allowBlasThreadParking(true);    // as `demnerf simulate` does: one thread calls BLAS here
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Arguments a = bench::keyValueArguments(argc, argv);
  const std::string name = text(a, "scenario", "beam3d");
  bench::MatrixCase mc;
  for (const bench::MatrixCase& c : bench::matrixCases())
    if (c.name == name) mc = c;
  if (mc.name.empty()) throw core::Error("unknown scenario '" + name + "'");
  const core::Scenario scenario = core::loadScenario(std::string(DEMNERF_ROOT) + "/config/scenarios/" + name + ".yaml");
  geo::SamplerConfig sampler;
  sampler.method = geo::parseSamplingMethod(text(a, "sampler", "grid"));
  const int div = std::stoi(text(a, "div", "6"));
  sampler.spacing = mc.smallest / div;
  sampler.seed = static_cast<std::uint64_t>(std::stoi(text(a, "seed", "1")));
  const std::string ref_dir = text(a, "ref", ""), source = text(a, "source", "exact");
  if (source != "exact" && (source != "nerf" || ref_dir.empty()))
    throw core::Error("source= is exact or nerf (with ref=, the matrix folder holding the cached surface)");
  const core::ParticleCloud cloud = geo::sampleParticles(
      source == "nerf" ? core::readMesh(ref_dir + "/nerf_" + mc.nerf_scene + "/extracted_mesh.ply") : mc.surface(), sampler);
  const std::vector<Vector3d> reference =
      referenceAt(ref_dir.empty() ? "" : ref_dir + "/reference_" + name + "_" + source + "_fine.ply", cloud);
  const dm::DemConfig config = configFrom(a);
  dm::DemSolver dem(cloud, scenario, config);
  dm::SolveControl control;
  control.time_limit = std::stod(text(a, "time_limit", "60"));
  if (text(a, "energy", "0") != "0") {  // the training energy once a second: an exploit shows as it falling far
    control.progress = [](const dm::SolveProgress& p) {
      std::printf("  [%s, iteration %d: training energy %.6g J]\n", p.phase.c_str(), p.iteration, p.energy);
    };
  }
  dem.setControl(control);
  const auto start = std::chrono::steady_clock::now();
  const double cpu0 = bench::processCpuSeconds();
  double spent_wall = 0.0, spent_cpu = 0.0;  // in the readings, not the solve
  const int every = std::stoi(text(a, "every", "25"));
  dem.setProgressCallback([&](int iteration) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = bench::processCpuSeconds();
    const Reading r = read(dem, cloud, mc, reference);
    std::printf("  it %5d  wall %7.2f s  cpu %7.2f s  tip %+.5f  rel L2 %.3f %%\n", iteration,
                bench::since(start) - spent_wall, c0 - cpu0 - spent_cpu, r.tip, 100 * r.rel_l2);
    spent_wall += bench::since(t0);
    spent_cpu += bench::processCpuSeconds() - c0;
  }, every);
  std::printf("%s %s 1/%d: %zu particles, network %dx%d %s, %s boundary\n", name.c_str(), text(a, "sampler", "grid").c_str(),
              div, cloud.size(), config.network.width, config.network.depth, config.network.activation.c_str(),
              config.boundary.kind == dm::DemConfig::Boundary::kPenalty ? "penalty" : "exact");
  std::string verdict = "converged";
  dm::DemReport report;
  try {
    report = dem.solve();
  } catch (const std::exception& e) {
    verdict = std::string("REFUSED: ") + e.what();
  }
  const double wall = bench::since(start) - spent_wall, cpu = bench::processCpuSeconds() - cpu0 - spent_cpu;
  const Reading r = read(dem, cloud, mc, reference);
  if (!reference.empty() && a.count("bands")) printBands(text(a, "bands", ""), cloud.positions, dem.predict(cloud.positions), reference);
  char tip_error[48] = "";  // against the reference code's Beam3D tip; other scenarios have none
  if (name == "beam3d") std::snprintf(tip_error, sizeof tip_error, " (%+.2f %% vs -1.2054)", 100 * (r.tip / -1.2054 - 1));
  std::printf("RESULT %s 1/%d: wall %.2f s, cpu %.2f s, its %d, energy %.6g, residual %.3g, tip %+.5f%s, rel L2 %.3f "
              "%%: %s\n",
              name.c_str(), div, wall, cpu, report.iterations, report.energy, report.residual, r.tip, tip_error,
              100 * r.rel_l2, verdict.c_str());
  return 0;
}
