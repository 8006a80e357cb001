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
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;

using demnerf::bench::median;
using demnerf::bench::relativeL2;
using demnerf::bench::since;
using demnerf::bench::tbarParticles;

namespace {

struct Row {
  std::string solver;
  double seconds;
  std::vector<Vector3d> u;
  std::size_t size;
};

/// FEM: TET10 on voxel meshes of the T-bar's surface, coarse to fine (the finest is the reference).
std::vector<Row> femLevels(const core::Scenario& scenario, const core::ParticleCloud& cloud, int levels) {
  const core::TriangleMesh surface = demnerf::bench::tbarSurface();
  const double cells[] = {0.02, 0.015, 0.01, 0.0075};
  std::vector<Row> rows;
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
  return rows;
}

struct DemRuns {
  std::vector<double> seconds, errors, predict_ms;
};

/// DEM: three trainings from different seeds (the MLP alone), each then predicting 10k random
/// points three times.
DemRuns demRuns(const core::Scenario& scenario, const core::ParticleCloud& cloud, int iterations,
                const std::vector<Vector3d>& reference) {
  DemRuns runs;
  for (int seed = 1; seed <= 3; ++seed) {
    dm::DemConfig config;
    config.adam.iterations = iterations;
    config.grid.spacings = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
    config.grid.body_cells = 0.0;
    config.network.seed = seed;
    dm::DemSolver dem(cloud, scenario, config);
    const dm::DemReport r = dem.solve();
    runs.seconds.push_back(r.seconds);
    runs.errors.push_back(relativeL2(dem.predict(cloud.positions), reference));
    const std::vector<Vector3d> points = demnerf::bench::pointsInTbar(10000, seed);
    for (int rep = 0; rep < 3; ++rep) {
      const auto start = std::chrono::steady_clock::now();
      const auto u = dem.predict(points);
      runs.predict_ms.push_back(1e3 * since(start));
    }
    std::fprintf(stderr, "dem seed %d: %.2f s, rel L2 %.4f, energy %.5g\n", seed, r.seconds, runs.errors.back(),
                 r.energy);
  }
  return runs;
}

}  // namespace

int main(int argc, char** argv) {
  demnerf::mechanics::keepLargeAllocationsInHeap();  // as the product's entry points do (tune_allocator)
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // keep the table when a later stage aborts
  const std::string scenario_path = argc > 1 ? argv[1] : std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml";
  const double h = argc > 2 ? std::atof(argv[2]) : 0.0075;
  const int levels = argc > 3 ? std::atoi(argv[3]) : 3;
  const int dem_iterations = argc > 4 ? std::atoi(argv[4]) : 400;
  const core::Scenario scenario = core::loadScenario(scenario_path);
  const core::ParticleCloud cloud = tbarParticles(h);
  std::printf("T-bar: %zu particles (cell %.4f m), scenario %s\n\n", cloud.size(), h, scenario_path.c_str());

  const std::vector<Row> rows = femLevels(scenario, cloud, levels);
  const Row& ref = rows.back();
  const DemRuns dem = demRuns(scenario, cloud, dem_iterations, ref.u);

  std::printf("| solver | particles | time (s) | rel. L2 vs finest FEM | predict 10k (ms) |\n| --- | --- | --- | --- | --- |\n");
  for (const Row& row : rows)
    std::printf("| %s | %zu | %.2f | %.4f | - |\n", row.solver.c_str(), cloud.size(), row.seconds,
                relativeL2(row.u, ref.u));
  std::printf("| DEM exact BCs, %d Adam its/step (median of 3 seeds) | %zu | %.2f | %.4f (min %.4f, max %.4f) | %.1f |\n",
              dem_iterations, cloud.size(), median(dem.seconds), median(dem.errors),
              *std::min_element(dem.errors.begin(), dem.errors.end()),
              *std::max_element(dem.errors.begin(), dem.errors.end()), median(dem.predict_ms));
  std::printf("| PINN | - | not built yet | - | - |\n");
  std::printf("\ntargets: DEM training <= 10 s, rel. L2 <= 0.05, predict 10k <= 50 ms\n");
  return 0;
}
