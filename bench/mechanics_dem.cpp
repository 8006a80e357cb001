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
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

using demnerf::bench::inTbar;
using demnerf::bench::median;
using demnerf::bench::since;
using demnerf::bench::tbarParticles;

namespace {

core::Scenario uniaxial(double p11) { return dm::uniaxialTractionScenario(p11); }

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::map<std::string, std::string> a = demnerf::bench::keyValueArguments(argc, argv);
  auto num = [&](const char* k, double d) { return a.count(k) ? std::atof(a[k].c_str()) : d; };
  const std::string which = a.count("case") ? a["case"] : "tbar";
  dm::DemConfig config;
  // The MLP alone unless grid= or grid_spacings= asks for the feature grid (DemConfig's default).
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
  if (a.count("quadrature") && a["quadrature"] == "particles")
    config.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;
  config.grid.extension_fill = num("extension", config.grid.extension_fill);
  config.load_steps = static_cast<int>(num("dem_steps", config.load_steps));
  if (a.count("activation")) config.network.activation = a["activation"];
  if (a.count("boundary") && a["boundary"] == "penalty") config.boundary.kind = dm::DemConfig::Boundary::kPenalty;
  const int seeds = static_cast<int>(num("seeds", 3));

  core::Scenario scenario;
  core::ParticleCloud cloud;
  std::vector<Vector3d> ref;
  if (which == "uniaxial") {
    const int n = static_cast<int>(num("cells", 6));
    cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(n, n, n));
    scenario = uniaxial(2e5);
    double b = 0;
    const double s = dm::uniaxialStretchForStress(*dm::makeMaterial(scenario.material), 2e5, &b);
    for (const auto& X : cloud.positions) ref.emplace_back((s - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
  } else {
    scenario = core::loadScenario(a.count("scenario") ? a["scenario"]
                                                      : std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml");
    const double h = num("h", 0.0075), fem_h = num("fem_h", 0.01);
    cloud = tbarParticles(h);
    // Default reference: the converged FEM (bench/mechanics_tbar_fem, finest level) at these grid
    // particles. fem_h=... or fem_cache=... ask for an FEM solve at that mesh size instead.
    const std::string reference = a.count("reference") ? a["reference"]
                                                       : std::string(DEMNERF_ROOT) + "/bench/data/tbar_twist_fem_reference.ply";
    if (!a.count("fem_h") && !a.count("fem_cache") && std::ifstream(reference).good()) {
      const core::ResultField field = core::readResult(reference);
      bool same = field.size() == cloud.size();
      for (std::size_t i = 0; same && i < cloud.size(); ++i) same = (field.positions[i] - cloud.positions[i]).norm() < 1e-6;
      if (same) {
        ref = field.displacements;
        std::fprintf(stderr, "FEM reference: %s\n", reference.c_str());
      } else {
        std::fprintf(stderr, "%s holds other particles than h=%g: solving the FEM at fem_h=%g instead\n", reference.c_str(), h, fem_h);
      }
    }
    const std::string cache = a.count("fem_cache") ? a["fem_cache"]
                                                   : "/tmp/dem_tbar_fem_" + std::to_string(h) + "_" + std::to_string(fem_h) + ".bin";
    std::ifstream in(ref.empty() ? cache : std::string(), std::ios::binary);
    if (in) {
      ref.resize(cloud.size());
      in.read(reinterpret_cast<char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(Vector3d)));
      if (!in) ref.clear();
    }
    if (ref.empty()) {
      core::TriangleMesh surface = dm::boxSurface(Vector3d(-0.03, -0.03, 0.0), Vector3d(0.03, 0.03, 0.24));
      const core::TriangleMesh bar = dm::boxSurface(Vector3d(-0.15, -0.03, 0.24), Vector3d(0.15, 0.03, 0.30));
      for (const auto& f : bar.faces) surface.faces.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
      surface.vertices.insert(surface.vertices.end(), bar.vertices.begin(), bar.vertices.end());
      dm::VoxelMeshConfig voxel;
      voxel.cell = fem_h;
      voxel.order = 2;
      const auto start = std::chrono::steady_clock::now();
      dm::FemSolver fem(dm::voxelMeshFromSurface(surface, voxel), scenario);
      fem.solve();
      ref = fem.interpolate(cloud.positions).displacement;
      std::fprintf(stderr, "FEM TET10 h=%g: %.1f s (cached in %s)\n", fem_h, since(start), cache.c_str());
      std::ofstream out(cache, std::ios::binary);
      out.write(reinterpret_cast<const char*>(ref.data()), static_cast<std::streamsize>(ref.size() * sizeof(Vector3d)));
    }
  }
  if (a.count("steps")) scenario.load_steps = static_cast<int>(num("steps", 1));
  double ref_norm = 0, ref_max = 0;
  for (const auto& r : ref) {
    ref_norm += r.squaredNorm();
    ref_max = std::max(ref_max, r.norm());
  }

  std::vector<double> seconds, errors, predict_ms;
  std::printf("| case | particles | net | Adam its x steps | L-BFGS | seed | time (s) | rel L2 | max err / max |u| | energy (J) | out scale |\n");
  for (int seed = 1; seed <= seeds; ++seed) {
    config.network.seed = seed;
    dm::DemSolver dem(cloud, scenario, config);
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
    // Prediction time for 10k random points inside the body (median of 3).
    std::mt19937 rng(seed);
    std::vector<Vector3d> points;
    if (which == "uniaxial") {
      std::uniform_real_distribution<double> u01(0, 1);
      while (points.size() < 10000) points.emplace_back(u01(rng), u01(rng), u01(rng));
    } else {
      std::uniform_real_distribution<double> ux(-0.15, 0.15), uy(-0.03, 0.03), uz(0.0, 0.30);
      while (points.size() < 10000) {
        const Vector3d p(ux(rng), uy(rng), uz(rng));
        if (inTbar(p)) points.push_back(p);
      }
    }
    std::vector<double> ms;
    for (int rep = 0; rep < 3; ++rep) {
      const auto start = std::chrono::steady_clock::now();
      const auto v = dem.predict(points);
      ms.push_back(1e3 * since(start));
    }
    predict_ms.push_back(median(ms));
  }
  std::printf("median: time %.2f s, rel L2 %.4f (min %.4f, max %.4f), predict 10k %.1f ms\n", median(seconds),
              median(errors), *std::min_element(errors.begin(), errors.end()),
              *std::max_element(errors.begin(), errors.end()), median(predict_ms));
  return 0;
}
