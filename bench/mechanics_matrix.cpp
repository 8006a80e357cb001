// The solver matrix (issue 13): every scenario of config/scenarios/ that the matrix names, on
// particle clouds from the product's own samplers (random, Poisson, grid) at spacings of 1/6,
// 1/10 and 1/15 of the body's smallest dimension, from the exact surface and (T-bar, cuboid) a
// 60 s NeRF's extracted surface, solved by the default DEM (feature grid, Newton only), the
// paper's DEM (MLP alone; penalty or exact boundary) and FEM TET10, all through
// mechanics::simulate() as `demnerf simulate` solves them. Each cell is compared with a reference
// FEM TET10 on a CGAL Mesh_3 mesh of the same surface, solved at two mesh sizes (the coarse one
// shows how converged the fine one is).
//
// Usage: mechanics_matrix key=value ...
//   scenarios=tbar_twist,cuboid_twist,cantilever_bending,uniaxial_compression,self_weight_sag,
//             cook_membrane_plane_strain,beam3d   (default: all)
//   samplers=random,poisson,grid   spacings=6,10,15 (divisors of the smallest dimension)
//   sources=exact,nerf   solvers=fem,dem,dem_mlp,dem_mlp_exact,dem_mlp_gn (and the comparison columns
//             fem_cloud: FEM TET10 on the particles' own surface, no mesh given;
//             dem_particles: the earlier default DEM; dem_cells, dem_ext: cell quadrature
//             without / with extended B-splines at 2 particle spacings, with
//             grid_spacings=2 ext_fill=0.75 levels=1, or body_cells=N: cells from the body's volume)
//   time_limit=60 (s per cell)   mlp_iters=N mlp_lbfgs=N (paper's DEM: Adam steps, then L-BFGS iterations, per
//             load step; default: paperDemConfig()'s)   gn_steps=N (dem_mlp_gn's steps; default the file's 80)
//   fem_div=0 (FEM column's mesh size = smallest dimension / fem_div; 0: the CLI's automatic size)
//   ref_div=8 conv_div=6 (reference FEM cells: smallest dimension / these)   ref_time_limit=1800
//   nerf_seconds=60, or nerf_cpu_seconds=C (a CPU budget, 2 x seconds on an idle 2-core machine)
//   nerf_config=FILE (a NeRF YAML over the defaults for the NeRF rows, e.g. `train: {seed: 2}`: another draw)
//   seed=1   yaml=PATH (one scenario: this YAML instead of config/scenarios/<name>.yaml, same surface)
//   out=DIR (default output/bench/mechanics_matrix: reference and NeRF caches, CSV/MD/PNG)
//   docs=DIR (default docs/ for a full run, none for quick=1 or a subset): DIR/mechanics_matrix.{csv,md,png}
//   config=FILE (the dem column's settings, as --config)   rows=SAMPLER/DIV,... (cells on these rows only)
//   clouds=DIR (write each row's cloud to DIR/<scenario>_<source>_<sampler>_<divisor>.ply)
//   quick=1: beam3d, grid sampler, coarsest spacing, exact surface, solvers fem,dem (a smoke run)
// Prints one line per cell as it finishes and the Markdown table at the end.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/compare_results.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_nerf.hpp"
#include "mechanics_matrix_reference.hpp"
#include "mechanics_matrix_report.hpp"
#include "mechanics_matrix_settings.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
namespace geo = demnerf::geometry;
namespace bench = demnerf::bench;
using Eigen::Vector3d;

namespace {

// The solver columns: what `demnerf simulate` runs for each, with the bench's time limit.
dm::SimulateOptions solverOptions(const std::string& solver, const bench::MatrixSettings& s, const core::TriangleMesh& surface,
                                  double smallest) {
  dm::SimulateOptions o;
  o.control.time_limit = s.time_limit;
  if (solver == "fem" || solver == "fem_cloud") {
    // `--solver fem --order 2 --mesh mesh.ply`; fem_cloud: the trusted FEM given only what the
    // DEM gets, the particles' own surface (no --mesh). Against the reference on the surface
    // itself, fem_cloud shows how far the cloud pins that surface down.
    if (solver == "fem") o.surface = surface;
    o.voxel.cell = s.fem_div > 0 ? smallest / s.fem_div : 0.0;
    o.voxel.order = 2;
  } else if (solver == "dem") {
    // DemConfig's defaults, as `demnerf simulate` runs them: the body-sized grid, cell
    // quadrature, extended B-splines, Newton only (config=: a settings file over them).
    if (!s.config.empty()) o = dm::loadSolverConfig(s.config, o);
  } else if (solver == "dem_particles") {
    o.dem.grid.spacings = 2;  // the earlier default: cells of 2 particle spacings, particle quadrature
    o.dem.grid.body_cells = 0;
    o.dem.grid.quadrature = dm::DemConfig::GridQuadrature::kParticles;
    o.dem.grid.extension_fill = 0;
    o.dem.grid.cell = 0;
    o.dem.adam.iterations = 0;
  } else if (solver == "dem_cells" || solver == "dem_ext") {
    // The sampler-independent quadrature (Gauss points in the cells inside the body), without and
    // with extended B-splines; grid_spacings= and ext_fill= set the grid and the fill threshold.
    o.dem.grid.spacings = s.body_cells > 0 ? 0.0 : s.grid_spacings;
    o.dem.grid.body_cells = s.body_cells;
    o.dem.grid.cell = 0;
    o.dem.adam.iterations = 0;
    o.dem.grid.quadrature = dm::DemConfig::GridQuadrature::kCells;
    o.dem.grid.boundary_levels = s.boundary_levels;
    o.dem.grid.extension_fill = solver == "dem_ext" ? s.extension_fill : 0.0;
  } else if (solver == "dem_mlp" || solver == "dem_mlp_exact") {
    o.dem = dm::paperDemConfig();  // `--method mlp`, with the penalty boundary or the exact one
    if (s.mlp_iters >= 0) o.dem.adam.iterations = s.mlp_iters;
    if (s.mlp_lbfgs >= 0) o.dem.lbfgs.iterations = s.mlp_lbfgs;
    o.dem.boundary.kind = solver == "dem_mlp" ? dm::DemConfig::Boundary::kPenalty : dm::DemConfig::Boundary::kExact;
  } else if (solver == "dem_mlp_gn") {
    // The MLP alone trained by Gauss-Newton steps instead of L-BFGS (docs/dem_feature_grid.md), as
    // `--method mlp --config config/dem_mlp_gauss_newton.yaml` reads the shipped file.
    const double limit = o.control.time_limit;
    o = dm::solverDefaults("mlp", std::string(DEMNERF_ROOT) + "/config/dem_mlp_gauss_newton.yaml");
    o.control.time_limit = limit;
    if (s.gn_steps >= 0) o.dem.gauss_newton.steps = s.gn_steps;
  } else {
    throw core::Error("unknown solver column '" + solver + "': use fem, fem_cloud, dem, dem_particles, dem_cells, dem_ext, dem_mlp, dem_mlp_exact or dem_mlp_gn");
  }
  return o;
}

dm::SolverChoice solverChoice(const std::string& solver) {
  return solver == "fem" || solver == "fem_cloud" ? dm::SolverChoice::kFem : dm::SolverChoice::kDem;
}

void append(core::ParticleCloud& all, const core::ParticleCloud& part) {
  all.positions.insert(all.positions.end(), part.positions.begin(), part.positions.end());
  all.volumes.insert(all.volumes.end(), part.volumes.begin(), part.volumes.end());
  all.normals.insert(all.normals.end(), part.normals.begin(), part.normals.end());
  all.areas.insert(all.areas.end(), part.areas.begin(), part.areas.end());
  all.colors.insert(all.colors.end(), part.colors.begin(), part.colors.end());
}

core::ResultField slice(const core::ResultField& field, std::size_t begin, std::size_t count) {
  core::ResultField out;
  out.positions.assign(field.positions.begin() + begin, field.positions.begin() + begin + count);
  out.displacements.assign(field.displacements.begin() + begin, field.displacements.begin() + begin + count);
  out.von_mises.assign(field.von_mises.begin() + begin, field.von_mises.begin() + begin + count);
  return out;
}

// One solver on one cloud: converged (with errors against the reference when there is one) or the
// failure's cause and message.
bench::MatrixCell runCell(const std::string& solver, const core::ParticleCloud& cloud, const core::Scenario& scenario,
                          const core::TriangleMesh& surface, double smallest, const bench::MatrixSettings& s,
                          const core::ResultField* reference, double reference_energy) {
  bench::MatrixCell cell;
  cell.solver = solver;
  const auto start = std::chrono::steady_clock::now();
  try {
    const dm::SimulationOutcome out = dm::simulate(cloud, scenario, solverChoice(solver), solverOptions(solver, s, surface, smallest));
    cell.seconds = bench::since(start);
    cell.converged = true;
    cell.reason = out.coarse_grid;  // what `demnerf simulate` would warn of: a stiff answer
    cell.energy = out.energy;
    if (reference) {
      const dm::ResultComparison c = dm::compareResults(out.field, *reference);
      double max_u = 0;
      for (const Vector3d& u : reference->displacements) max_u = std::max(max_u, u.norm());
      cell.has_error = true;
      cell.rel_l2 = c.rel_l2;
      cell.max_error = c.max_error;
      cell.max_error_rel = c.max_error / max_u;
      cell.energy_error = (out.energy - reference_energy) / std::abs(reference_energy);
    }
  } catch (const dm::SolveError& e) {
    cell.seconds = bench::since(start);
    cell.failure = dm::solveFailureName(e.failure());
    cell.reason = e.what();
  } catch (const std::exception& e) {  // core::Error (bad input, a failed solve) and anything else
    cell.seconds = bench::since(start);
    cell.failure = "error";
    cell.reason = e.what();
  }
  return cell;
}

void printCell(const bench::MatrixRow& row, const bench::MatrixCell& c) {
  if (!c.converged) {
    std::printf("%s %s %s 1/%d (%zu): %-13s FAIL %s after %.1f s: %s\n", row.scenario.c_str(), row.source.c_str(),
                row.sampler.c_str(), row.spacing_divisor, row.particles, c.solver.c_str(), c.failure.c_str(), c.seconds,
                c.reason.c_str());
  } else {
    std::printf("%s %s %s 1/%d (%zu): %-13s %.1f s, energy %.6g, rel L2 %s, max err %.3g %% of max|u|, energy err %+.3g %%\n",
                row.scenario.c_str(), row.source.c_str(), row.sampler.c_str(), row.spacing_divisor, row.particles,
                c.solver.c_str(), c.seconds, c.energy, c.has_error ? (std::to_string(100 * c.rel_l2) + " %").c_str() : "-",
                100 * c.max_error_rel, 100 * c.energy_error);
    if (!c.reason.empty()) std::printf("  warning: %s\n", c.reason.c_str());
  }
  std::fflush(stdout);
}

void writeOutputs(const bench::MatrixReport& report, const bench::MatrixSettings& s) {
  for (const std::string& dir : {s.out, s.docs}) {
    if (dir.empty()) continue;
    std::filesystem::create_directories(dir);
    bench::writeCsv(report, dir + "/mechanics_matrix.csv");
    std::ofstream(dir + "/mechanics_matrix.md") << bench::markdown(report);
    bench::writeHeatMap(report, dir + "/mechanics_matrix.png");
  }
}

// A row's cloud as a PLY, so that one cell can be run again through `demnerf simulate` (the PLY
// stores floats: a solve that depends on the last digits shows it there).
void writeCloud(const std::string& dir, const bench::MatrixRow& row, const core::ParticleCloud& cloud) {
  std::filesystem::create_directories(dir);
  core::writeParticles(dir + "/" + row.scenario + "_" + row.source + "_" + row.sampler + "_" +
                           std::to_string(row.spacing_divisor) + ".ply",
                       cloud);
}

// The clouds of one scenario x source (a row per sampler x spacing), and their union plus the
// scenario's sanity probes, on which the reference is solved once.
struct SourceClouds {
  std::vector<bench::MatrixRow> rows;
  std::vector<core::ParticleCloud> clouds;
  std::vector<std::size_t> offsets;  ///< of each cloud in `all`
  core::ParticleCloud all;
  std::size_t probes_at = 0;
};

SourceClouds sampleClouds(const bench::MatrixCase& mc, const std::string& source, const core::TriangleMesh& surface,
                          const bench::MatrixSettings& s) {
  SourceClouds out;
  for (const std::string& sampler : s.samplers)
    for (int divisor : s.divisors) {
      bench::MatrixRow row{mc.name, source, sampler, divisor, mc.smallest / divisor};
      geo::SamplerConfig config;
      core::ParticleCloud cloud;
      try {
        config.method = geo::parseSamplingMethod(sampler);
        config.spacing = row.spacing;
        config.seed = static_cast<std::uint64_t>(s.seed);
        cloud = geo::sampleParticles(surface, config);
        row.particles = cloud.size();
        if (!s.clouds.empty()) writeCloud(s.clouds, row, cloud);
      } catch (const std::exception& e) {
        row.cloud_error = e.what();
        std::printf("%s %s %s 1/%d: sampler failed: %s\n", mc.name.c_str(), source.c_str(), sampler.c_str(), divisor,
                    e.what());
      }
      out.offsets.push_back(out.all.size());
      append(out.all, cloud);
      out.clouds.push_back(std::move(cloud));
      out.rows.push_back(row);
    }
  out.probes_at = out.all.size();
  for (const bench::Probe& p : mc.probes) {
    core::ParticleCloud probe;
    probe.resize(1);
    probe.positions[0] = p.point;
    probe.volumes[0] = 0.0;
    probe.areas[0] = 0.0;
    probe.normals[0] = Vector3d::Zero();
    probe.colors[0] = {0, 0, 0};
    append(out.all, probe);
  }
  return out;
}

// The reference FEM at two mesh sizes, its convergence and sanity row (printed); returns the fine one.
bench::Reference referencePair(const bench::MatrixCase& mc, const core::Scenario& scenario, const std::string& source,
                               const core::TriangleMesh& surface, const bench::MatrixSettings& s, const SourceClouds& sc,
                               bench::MatrixReport& report) {
  bench::ConvergenceRow conv{mc.name, source};
  const std::string stem = s.out + "/reference_" + mc.name + "_" + source;
  std::fprintf(stderr, "%s / %s: reference FEM TET10 on %zu points\n", mc.name.c_str(), source.c_str(), sc.all.size());
  bench::Reference fine =
      bench::referenceFem(sc.all, scenario, surface, mc.smallest / s.ref_div, s.ref_time_limit, stem + "_fine");
  const bench::Reference coarse =
      bench::referenceFem(sc.all, scenario, surface, mc.smallest / s.conv_div, s.ref_time_limit, stem + "_coarse");
  conv.fine_cell = fine.cell, conv.coarse_cell = coarse.cell;
  conv.fine_dofs = fine.dofs, conv.coarse_dofs = coarse.dofs;
  conv.fine_seconds = fine.seconds, conv.coarse_seconds = coarse.seconds;
  conv.fine_energy = fine.energy, conv.coarse_energy = coarse.energy;
  conv.error = !fine.error.empty() ? "fine: " + fine.error : (!coarse.error.empty() ? "coarse: " + coarse.error : "");
  if (fine.error.empty()) {
    std::vector<Vector3d> at;
    for (std::size_t i = sc.probes_at; i < sc.all.size(); ++i) at.push_back(fine.field.displacements[i]);
    const bench::Sanity sanity = mc.check(at);
    conv.sanity = sanity.text, conv.sanity_ok = sanity.ok;
    if (coarse.error.empty()) conv.rel_l2 = dm::compareResults(coarse.field, fine.field).rel_l2;
  }
  if (!conv.error.empty()) {
    std::printf("%s %s reference FAILED%s: %s\n", mc.name.c_str(), source.c_str(),
                fine.error.empty() ? " (the coarse check only; cells use the fine one)" : " (cells get no errors)",
                conv.error.c_str());
  } else {
    std::printf("%s %s reference: fine h=%.4g (%d dofs, %.1f s) vs coarse h=%.4g: rel L2 %.3f %%%s; sanity: %s%s\n",
                mc.name.c_str(), source.c_str(), fine.cell, fine.dofs, fine.seconds, coarse.cell, 100 * conv.rel_l2,
                conv.rel_l2 < 0.005 ? "" : " (NOT converged to 0.5 %)", conv.sanity_ok ? "" : "CHECK FAILED: ",
                conv.sanity.c_str());
  }
  report.convergence.push_back(conv);
  return fine;
}

// Every row (and its solver cells) of one scenario from one surface.
void runSource(const bench::MatrixCase& mc, const core::Scenario& scenario, const std::string& source,
               const core::TriangleMesh& surface, const bench::MatrixSettings& s, bench::MatrixReport& report) {
  SourceClouds sc = sampleClouds(mc, source, surface, s);
  const bench::Reference fine = referencePair(mc, scenario, source, surface, s, sc, report);
  for (std::size_t r = 0; r < sc.rows.size(); ++r) {
    bench::MatrixRow& row = sc.rows[r];
    const std::string key = row.sampler + "/" + std::to_string(row.spacing_divisor);
    if (row.cloud_error.empty() && (s.rows.empty() || std::count(s.rows.begin(), s.rows.end(), key))) {
      core::ResultField reference;
      if (fine.error.empty()) {
        reference = slice(fine.field, sc.offsets[r], sc.clouds[r].size());
        row.reference_energy = fine.energy;
        for (const Vector3d& u : reference.displacements) row.reference_max_u = std::max(row.reference_max_u, u.norm());
      }
      for (const std::string& solver : s.solvers) {
        row.cells.push_back(runCell(solver, sc.clouds[r], scenario, surface, mc.smallest, s,
                                    fine.error.empty() ? &reference : nullptr, fine.energy));
        printCell(row, row.cells.back());
      }
    }
    report.rows.push_back(row);
    writeOutputs(report, s);  // a run stopped early keeps what it measured
  }
}

}  // namespace

int main(int argc, char** argv) {
  demnerf::mechanics::keepLargeAllocationsInHeap();  // as the product's entry points do (tune_allocator)
  demnerf::mechanics::allowBlasThreadParking(true);   // as `demnerf simulate` does
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const bench::MatrixSettings s = bench::parseMatrixSettings(argc, argv);
  bench::MatrixReport report;
  report.title = s.title;
  report.partial = s.partial;
  report.solvers = s.solvers;
  std::filesystem::create_directories(s.out);
  for (const std::string& solver : s.solvers) solverOptions(solver, s, {}, 1.0);  // unknown names fail before any work
  const std::vector<bench::MatrixCase> cases = bench::matrixCases();
  for (const std::string& name : s.scenarios) {
    const auto mc = std::find_if(cases.begin(), cases.end(), [&](const bench::MatrixCase& c) { return c.name == name; });
    if (mc == cases.end()) {
      std::fprintf(stderr, "unknown scenario '%s'\n", name.c_str());
      return 2;
    }
    const core::Scenario scenario =
        core::loadScenario(s.yaml.empty() ? std::string(DEMNERF_ROOT) + "/config/scenarios/" + name + ".yaml" : s.yaml);
    for (const std::string& source : s.sources) {
      if (source == "nerf" && mc->nerf_scene.empty()) continue;  // NeRF rows: T-bar and cuboid only
      core::TriangleMesh surface;
      try {
        if (source == "exact") {
          surface = mc->surface();
        } else if (source == "nerf") {
          surface = bench::nerfSurface(
              {mc->nerf_scene, s.out + "/nerf_" + mc->nerf_scene, s.nerf_seconds, s.nerf_cpu_seconds, s.nerf_config});
        } else {
          throw core::Error("unknown source '" + source + "': use exact or nerf");
        }
      } catch (const std::exception& e) {
        std::printf("%s %s: no surface: %s\n", name.c_str(), source.c_str(), e.what());
        bench::ConvergenceRow conv{name, source};
        conv.error = std::string("no surface: ") + e.what();
        report.convergence.push_back(conv);
        continue;
      }
      runSource(*mc, scenario, source, surface, s, report);
    }
  }
  writeOutputs(report, s);
  std::printf("\n%s", bench::markdown(report).c_str());
  return 0;
}
