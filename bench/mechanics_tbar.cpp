// T-bar twist (config/scenarios/tbar_twist.yaml): FEM mesh convergence on voxel tetrahedra, then
// the Deep Energy Method's training time and relative L2 displacement error against the finest
// FEM, and its prediction time for 10k points. Prints a markdown table.
// Usage: mechanics_tbar [scenario.yaml] [particle_cell_m=0.0075] [fem_levels=3] [dem_iterations=400]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "mechanics_bench_common.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

using demnerf::bench::inTbar;
using demnerf::bench::median;
using demnerf::bench::since;
using demnerf::bench::tbarParticles;

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // keep the table when a later stage aborts
  const std::string scenario_path = argc > 1 ? argv[1] : std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml";
  const double h = argc > 2 ? std::atof(argv[2]) : 0.0075;
  const int levels = argc > 3 ? std::atoi(argv[3]) : 3;
  const int dem_iterations = argc > 4 ? std::atoi(argv[4]) : 400;
  const core::Scenario scenario = core::loadScenario(scenario_path);
  const core::ParticleCloud cloud = tbarParticles(h);
  std::printf("T-bar: %zu particles (cell %.4f m), scenario %s\n\n", cloud.size(), h, scenario_path.c_str());

  struct Row {
    std::string solver;
    double seconds;
    std::vector<Vector3d> u;
    std::size_t size;
  };
  std::vector<Row> rows;
  // FEM: TET10 on voxel meshes, coarse to fine; the finest is the reference.
  // The T-bar's surface: two closed boxes that touch at z = 0.24 (ray parity gives their union).
  core::TriangleMesh surface = dm::boxSurface(Vector3d(-0.03, -0.03, 0.0), Vector3d(0.03, 0.03, 0.24));
  const core::TriangleMesh bar = dm::boxSurface(Vector3d(-0.15, -0.03, 0.24), Vector3d(0.15, 0.03, 0.30));
  for (const auto& f : bar.faces) surface.faces.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
  surface.vertices.insert(surface.vertices.end(), bar.vertices.begin(), bar.vertices.end());
  const double cells[] = {0.02, 0.015, 0.01, 0.0075};
  for (int l = 0; l < levels && l < 4; ++l) {
    dm::VoxelMeshConfig voxel;
    voxel.cell = cells[l];
    voxel.order = 2;
    const auto start = std::chrono::steady_clock::now();
    dm::TetMesh mesh = dm::voxelMeshFromSurface(surface, voxel);
    const std::size_t dofs = 3 * mesh.nodes.size();
    dm::FemSolver fem(std::move(mesh), scenario);
    fem.solve();
    Row row{"FEM TET10 h=" + std::to_string(cells[l]).substr(0, 6) + " (" + std::to_string(dofs) + " dofs)", 0,
            fem.interpolate(cloud.positions).displacement, dofs};
    row.seconds = since(start);
    rows.push_back(row);
    std::fprintf(stderr, "fem level %d done in %.1f s\n", l, row.seconds);
  }
  const Row& ref = rows.back();
  auto relL2 = [&](const std::vector<Vector3d>& u) {
    double e = 0, r = 0;
    for (std::size_t i = 0; i < u.size(); ++i) {
      e += (u[i] - ref.u[i]).squaredNorm();
      r += ref.u[i].squaredNorm();
    }
    return std::sqrt(e / r);
  };

  // DEM: three trainings from different seeds (median time), then predict 10k random points.
  std::vector<double> dem_seconds, dem_errors, predict_ms;
  for (int seed = 1; seed <= 3; ++seed) {
    dm::DemConfig config;
    config.adam.iterations = dem_iterations;
    config.grid.spacings = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
    config.grid.body_cells = 0.0;
    config.network.seed = seed;
    dm::DemSolver dem(cloud, scenario, config);
    const dm::DemReport r = dem.solve();
    dem_seconds.push_back(r.seconds);
    dem_errors.push_back(relL2(dem.predict(cloud.positions)));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-0.15, 0.15), uy(-0.03, 0.03), uz(0.0, 0.30);
    std::vector<Vector3d> points;
    while (points.size() < 10000) {
      const Vector3d p(ux(rng), uy(rng), uz(rng));
      if (inTbar(p)) points.push_back(p);
    }
    for (int rep = 0; rep < 3; ++rep) {
      const auto start = std::chrono::steady_clock::now();
      const auto u = dem.predict(points);
      predict_ms.push_back(1e3 * since(start));
    }
    std::fprintf(stderr, "dem seed %d: %.2f s, rel L2 %.4f, energy %.5g\n", seed, r.seconds, dem_errors.back(), r.energy);
  }

  std::printf("| solver | particles | time (s) | rel. L2 vs finest FEM | predict 10k (ms) |\n| --- | --- | --- | --- | --- |\n");
  for (const Row& row : rows)
    std::printf("| %s | %zu | %.2f | %.4f | - |\n", row.solver.c_str(), cloud.size(), row.seconds, relL2(row.u));
  std::printf("| DEM exact BCs, %d Adam its/step (median of 3 seeds) | %zu | %.2f | %.4f (min %.4f, max %.4f) | %.1f |\n",
              dem_iterations, cloud.size(), median(dem_seconds), median(dem_errors),
              *std::min_element(dem_errors.begin(), dem_errors.end()),
              *std::max_element(dem_errors.begin(), dem_errors.end()), median(predict_ms));
  std::printf("| PINN | - | not built yet | - | - |\n");
  std::printf("\ntargets: DEM training <= 10 s, rel. L2 <= 0.05, predict 10k <= 50 ms\n");
  return 0;
}
