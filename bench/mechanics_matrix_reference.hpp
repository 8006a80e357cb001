#pragma once
// The solver matrix's reference: one FEM TET10 solve on a CGAL mesh of the surface at mesh size
// `cell`, on the union of a scenario x source's clouds, as mechanics::simulate() solves it;
// cached as a result PLY plus a line of figures in the out dir (a cache on other particles is
// solved again).

#include <Eigen/Geometry>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "mechanics_bench_common.hpp"

namespace demnerf::bench {

struct Reference {
  core::ResultField field;
  double energy = 0.0, seconds = 0.0, cell = 0.0;
  int dofs = 0;
  std::string error;
};

inline Reference referenceFem(const core::ParticleCloud& cloud, const core::Scenario& scenario,
                              const core::TriangleMesh& surface, double cell, double time_limit,
                              const std::string& stem) {
  Reference r;
  r.cell = cell;
  const std::string ply = stem + ".ply", figures = stem + ".txt";
  if (std::filesystem::exists(ply) && std::filesystem::exists(figures)) {
    core::ResultField field = core::readResult(ply);
    // Result PLYs hold floats: the same particles agree to float precision of the body's size.
    Eigen::AlignedBox3d box;
    for (const Vector3d& x : cloud.positions) box.extend(x);
    const double tolerance = 1e-6 * box.diagonal().norm();
    bool same = field.size() == cloud.size();
    for (std::size_t i = 0; same && i < cloud.size(); ++i) same = (field.positions[i] - cloud.positions[i]).norm() < tolerance;
    std::ifstream in(figures);
    if (same && (in >> r.energy >> r.dofs >> r.seconds)) {
      r.field = std::move(field);
      std::fprintf(stderr, "  reference h=%g: cached %s\n", cell, ply.c_str());
      return r;
    }
  }
  mechanics::SimulateOptions o;
  o.surface = surface;
  o.voxel.cell = cell;
  o.voxel.order = 2;
  o.control.time_limit = time_limit;
  o.control.progress_interval = 10.0;
  o.control.progress = [](const mechanics::SolveProgress& p) {
    std::fprintf(stderr, "    reference %s: load %.3f it %d residual %.2e, %.0f s\n", p.phase.c_str(), p.load_fraction,
                 p.iteration, p.residual, p.elapsed);
  };
  const auto start = std::chrono::steady_clock::now();
  try {
    const mechanics::SimulationOutcome out = mechanics::simulate(cloud, scenario, mechanics::SolverChoice::kFem, o);
    r.field = out.field;
    r.energy = out.energy;
    r.dofs = 3 * out.mesh_nodes;
    r.seconds = since(start);
    core::writeResult(ply, r.field);
    std::ofstream(figures) << std::setprecision(17) << r.energy << " " << r.dofs << " " << r.seconds << "\n";
    std::fprintf(stderr, "  reference h=%g: %d dofs, %.1f s, energy %.6g\n", cell, r.dofs, r.seconds, r.energy);
  } catch (const std::exception& e) {
    r.error = e.what();
    r.seconds = since(start);
    std::fprintf(stderr, "  reference h=%g FAILED after %.1f s: %s\n", cell, r.seconds, e.what());
  }
  return r;
}

}  // namespace demnerf::bench
