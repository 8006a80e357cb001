// DEM tuning bench: one Deep Energy Method configuration on the homogeneous uniaxial-traction cube
// (closed form) or the T-bar twist (against a cached TET10 FEM reference), with timings.
// Usage: mechanics_dem key=value ...
//   case=uniaxial|tbar  iters=N lr=R final=RATIO lbfgs=N width=W depth=D threads=T jitter=0|1
//   band=CELLS steps=LOAD_STEPS cells=N (uniaxial) h=M (T-bar particle cell) fem_h=M (T-bar FEM)
//   reference=RESULT.ply (default bench/data/tbar_twist_fem_reference.ply, the converged FEM)
//   fem_cache=PATH seeds=N double=0|1 verbose=0|1 activation=tanh|softplus|...
//   newton=0|1 newton_every=N newton_its=N (output-layer Newton, DemConfig::output_newton)
//   grid=CELL_M grid_degree=1|2|3 grid_band=CELLS dem_steps=N (feature grid, DemConfig::grid_cell)
//   quadrature=cells|particles extension=FILL (DemConfig::grid_quadrature, grid_extension_fill)
// Prints one markdown row per seed and the median time / error.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "mechanics_bench_common.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

using demnerf::bench::median;
using demnerf::bench::since;
using demnerf::bench::tbarParticles;

namespace {

using Arguments = std::map<std::string, std::string>;

core::Scenario uniaxial(double p11) { return dm::uniaxialTractionScenario(p11); }

double number(const Arguments& a, const char* key, double fallback) {
  const auto it = a.find(key);
  return it != a.end() ? std::atof(it->second.c_str()) : fallback;
}

std::string text(const Arguments& a, const char* key, const std::string& fallback) {
  const auto it = a.find(key);
  return it != a.end() ? it->second : fallback;
}

/// The DEM of the arguments: the MLP alone unless grid= or grid_spacings= asks for the feature
/// grid (DemConfig's default).
dm::DemConfig demConfig(const Arguments& a) {
  auto num = [&](const char* k, double d) { return number(a, k, d); };
  dm::DemConfig config;
  config.adam.iterations = static_cast<int>(num("iters", 1500));
  config.grid.spacings = num("grid_spacings", 0.0);
  config.grid.body_cells = num("grid_body_cells", 0.0);
  config.adam.learning_rate = num("lr", config.adam.learning_rate);
  config.adam.final_rate_ratio = num("final", config.adam.final_rate_ratio);
  config.lbfgs.iterations = static_cast<int>(num("lbfgs", 0));
  config.network.width = static_cast<int>(num("width", config.network.width));
  config.network.depth = static_cast<int>(num("depth", config.network.depth));
  config.threads = static_cast<int>(num("threads", 0));
  config.adam.jitter = num("jitter", 1) != 0;
  config.adam.jitter_band = num("band", config.adam.jitter_band);
  config.network.double_precision = num("double", 0) != 0;
  config.verbose = num("verbose", 0) != 0;
  config.adam.rescale_every = static_cast<int>(num("rescale", config.adam.rescale_every));
  config.lbfgs.max_energy_drop = num("drop", config.lbfgs.max_energy_drop);
  config.lbfgs.max_growth = num("growth", config.lbfgs.max_growth);
  config.lbfgs.history = static_cast<int>(num("history", config.lbfgs.history));
  config.output_newton.enabled = num("newton", config.output_newton.enabled ? 1 : 0) != 0;
  config.output_newton.every = static_cast<int>(num("newton_every", config.output_newton.every));
  config.output_newton.iterations = static_cast<int>(num("newton_its", config.output_newton.iterations));
  config.grid.cell = num("grid", config.grid.cell);
  config.grid.degree = static_cast<int>(num("grid_degree", config.grid.degree));
  config.grid.refine_band = num("grid_band", config.grid.refine_band);
  // quadrature=particles extension=0: the earlier default grid (the README's lattice T-bar rows).
  if (text(a, "quadrature", "") == "particles") config.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;
  config.grid.extension_fill = num("extension", config.grid.extension_fill);
  config.load_steps = static_cast<int>(num("dem_steps", config.load_steps));
  if (a.count("activation")) config.network.activation = a.at("activation");
  if (text(a, "boundary", "") == "penalty") config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  return config;
}

/// A body, its load case and the displacement the DEM is measured against, at its particles.
struct Problem {
  core::Scenario scenario;
  core::ParticleCloud cloud;
  std::vector<Vector3d> reference;
};

/// The cube in uniaxial traction, against the closed form.
Problem uniaxialProblem(int cells) {
  Problem p;
  p.cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(cells, cells, cells));
  p.scenario = uniaxial(2e5);
  double b = 0;
  const double s = dm::uniaxialStretchForStress(*dm::makeMaterial(p.scenario.material), 2e5, &b);
  for (const auto& X : p.cloud.positions) p.reference.emplace_back((s - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
  return p;
}

/// The stored converged FEM (bench/mechanics_tbar_fem, finest level) when it holds exactly these
/// particles; empty otherwise.
std::vector<Vector3d> storedReference(const std::string& path, const core::ParticleCloud& cloud, double h,
                                      double fem_h) {
  if (!std::ifstream(path).good()) return {};
  const core::ResultField field = core::readResult(path);
  bool same = field.size() == cloud.size();
  for (std::size_t i = 0; same && i < cloud.size(); ++i) same = (field.positions[i] - cloud.positions[i]).norm() < 1e-6;
  if (!same) {
    std::fprintf(stderr, "%s holds other particles than h=%g: solving the FEM at fem_h=%g instead\n", path.c_str(), h,
                 fem_h);
    return {};
  }
  std::fprintf(stderr, "FEM reference: %s\n", path.c_str());
  return field.displacements;
}

/// A TET10 FEM solve of the T-bar at mesh size fem_h, interpolated at the particles and cached.
std::vector<Vector3d> solveFemReference(const core::Scenario& scenario, const core::ParticleCloud& cloud, double fem_h,
                                        const std::string& cache) {
  const core::TriangleMesh surface = demnerf::bench::tbarSurface();
  dm::VoxelMeshConfig voxel;
  voxel.cell = fem_h;
  voxel.order = 2;
  const auto start = std::chrono::steady_clock::now();
  dm::FemSolver fem(dm::voxelMeshFromSurface(surface, voxel), scenario);
  fem.solve();
  std::vector<Vector3d> ref = fem.interpolate(cloud.positions).displacement;
  std::fprintf(stderr, "FEM TET10 h=%g: %.1f s (cached in %s)\n", fem_h, since(start), cache.c_str());
  std::ofstream out(cache, std::ios::binary);
  out.write(reinterpret_cast<const char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(Vector3d)));
  return ref;
}

/// The T-bar twist against the converged FEM at these grid particles by default; fem_h=... or
/// fem_cache=... ask for an FEM solve at that mesh size instead (cached between runs).
Problem tbarProblem(const Arguments& a) {
  Problem p;
  p.scenario = core::loadScenario(text(a, "scenario", std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml"));
  const double h = number(a, "h", 0.0075), fem_h = number(a, "fem_h", 0.01);
  p.cloud = tbarParticles(h);
  const std::string reference =
      text(a, "reference", std::string(DEMNERF_ROOT) + "/bench/data/tbar_twist_fem_reference.ply");
  if (!a.count("fem_h") && !a.count("fem_cache")) p.reference = storedReference(reference, p.cloud, h, fem_h);
  const std::string cache =
      text(a, "fem_cache", "/tmp/dem_tbar_fem_" + std::to_string(h) + "_" + std::to_string(fem_h) + ".bin");
  std::ifstream in(p.reference.empty() ? cache : std::string(), std::ios::binary);
  if (in) {
    p.reference.resize(p.cloud.size());
    in.read(reinterpret_cast<char*>(p.reference.data()),
            static_cast<std::streamsize>(p.reference.size() * sizeof(Vector3d)));
    if (!in) p.reference.clear();
  }
  if (p.reference.empty()) p.reference = solveFemReference(p.scenario, p.cloud, fem_h, cache);
  return p;
}

/// 10k random points inside the body, for the prediction timing.
std::vector<Vector3d> pointsInside(const std::string& which, int seed) {
  if (which != "uniaxial") return demnerf::bench::pointsInTbar(10000, seed);
  std::mt19937 rng(seed);
  std::vector<Vector3d> points;
  std::uniform_real_distribution<double> u01(0, 1);
  while (points.size() < 10000) points.emplace_back(u01(rng), u01(rng), u01(rng));
  return points;
}

/// Median of 3 prediction times, in ms.
double predictMilliseconds(const dm::DemSolver& dem, const std::vector<Vector3d>& points) {
  std::vector<double> ms;
  for (int rep = 0; rep < 3; ++rep) {
    const auto start = std::chrono::steady_clock::now();
    const auto v = dem.predict(points);
    ms.push_back(1e3 * since(start));
  }
  return median(ms);
}

}  // namespace

int main(int argc, char** argv) {
  demnerf::mechanics::keepLargeAllocationsInHeap();  // as the product's entry points do (tune_allocator)
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Arguments a = demnerf::bench::keyValueArguments(argc, argv);
  const std::string which = text(a, "case", "tbar");
  dm::DemConfig config = demConfig(a);
  const int seeds = static_cast<int>(number(a, "seeds", 3));
  Problem problem = which == "uniaxial" ? uniaxialProblem(static_cast<int>(number(a, "cells", 6))) : tbarProblem(a);
  const core::ParticleCloud& cloud = problem.cloud;
  const std::vector<Vector3d>& ref = problem.reference;
  if (a.count("steps")) problem.scenario.load_steps = static_cast<int>(number(a, "steps", 1));
  double ref_norm = 0, ref_max = 0;
  for (const auto& r : ref) {
    ref_norm += r.squaredNorm();
    ref_max = std::max(ref_max, r.norm());
  }

  std::vector<double> seconds, errors, predict_ms;
  std::printf("| case | particles | net | Adam its x steps | L-BFGS | seed | time (s) | rel L2 | max err / max |u| | energy (J) | out scale |\n");
  for (int seed = 1; seed <= seeds; ++seed) {
    config.network.seed = seed;
    dm::DemSolver dem(cloud, problem.scenario, config);
    const dm::DemReport r = dem.solve();
    const auto u = dem.predict(cloud.positions);
    double e = 0, emax = 0;
    for (std::size_t i = 0; i < u.size(); ++i) {
      e += (u[i] - ref[i]).squaredNorm();
      emax = std::max(emax, (u[i] - ref[i]).norm());
    }
    seconds.push_back(r.seconds);
    errors.push_back(std::sqrt(e / ref_norm));
    std::printf("| %s | %zu | %dx%d %s | %d x %d | %d%s | %d | %.2f | %.4f | %.4f | %.6g | %.3g |\n", which.c_str(),
                cloud.size(), config.network.width, config.network.depth, config.network.double_precision ? "f64" : "f32", config.adam.iterations,
                r.load_steps, config.lbfgs.iterations, r.polish_rejected ? " (rejected)" : "", seed, r.seconds,
                errors.back(), emax / ref_max, r.energy, r.output_scale);
    predict_ms.push_back(predictMilliseconds(dem, pointsInside(which, seed)));
  }
  std::printf("median: time %.2f s, rel L2 %.4f (min %.4f, max %.4f), predict 10k %.1f ms\n", median(seconds),
              median(errors), *std::min_element(errors.begin(), errors.end()),
              *std::max_element(errors.begin(), errors.end()), median(predict_ms));
  return 0;
}
