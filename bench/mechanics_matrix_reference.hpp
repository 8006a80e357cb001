#pragma once
// The solver matrix's reference: one FEM TET10 solve on a CGAL mesh of the surface at mesh size
// `cell`, on the union of a scenario x source's clouds, as mechanics::simulate() solves it;
// cached as a result PLY plus a line of figures in the out dir. A later run whose points are all
// in the cache (fewer samplers, `rows=`) at the same mesh size reads them from it; any other
// point or mesh size solves it again.

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>

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

// The cached field at `cloud`'s points, in its order, when every point is in the cache. Result
// PLYs hold floats: the same particles agree to float precision of the body's size, so points are
// matched within 1e-6 of the box's diagonal through a hash of cells twice that size.
inline std::optional<core::ResultField> cachedAt(const core::ResultField& cached, const core::ParticleCloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const Vector3d& x : cloud.positions) box.extend(x);
  const double tolerance = 1e-6 * std::max(box.diagonal().norm(), 1e-9);
  const double bucket = 2.0 * tolerance;
  const auto key = [&](const Eigen::Vector3i& c) {
    return (static_cast<std::int64_t>(c.x()) * 73856093) ^ (static_cast<std::int64_t>(c.y()) * 19349663) ^
           (static_cast<std::int64_t>(c.z()) * 83492791);
  };
  const auto cellOf = [&](const Vector3d& x) { return Eigen::Vector3i((x / bucket).array().floor().cast<int>()); };
  std::unordered_multimap<std::int64_t, std::size_t> index;
  for (std::size_t i = 0; i < cached.size(); ++i) index.emplace(key(cellOf(cached.positions[i])), i);
  core::ResultField out;
  out.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d& x = cloud.positions[i];
    const Eigen::Vector3i c = cellOf(x);
    std::optional<std::size_t> found;
    for (int dx = -1; dx <= 1 && !found; ++dx)
      for (int dy = -1; dy <= 1 && !found; ++dy)
        for (int dz = -1; dz <= 1 && !found; ++dz) {
          const auto [first, last] = index.equal_range(key(c + Eigen::Vector3i(dx, dy, dz)));
          for (auto it = first; it != last && !found; ++it)
            if ((cached.positions[it->second] - x).norm() < tolerance) found = it->second;
        }
    if (!found) return std::nullopt;
    out.positions[i] = cached.positions[*found];
    out.displacements[i] = cached.displacements[*found];
    out.von_mises[i] = cached.von_mises[*found];
  }
  return out;
}

inline Reference referenceFem(const core::ParticleCloud& cloud, const core::Scenario& scenario,
                              const core::TriangleMesh& surface, double cell, double time_limit,
                              const std::string& stem) {
  Reference r;
  r.cell = cell;
  const std::string ply = stem + ".ply", figures = stem + ".txt";
  if (std::filesystem::exists(ply) && std::filesystem::exists(figures)) {
    std::optional<core::ResultField> field = cachedAt(core::readResult(ply), cloud);
    std::ifstream in(figures);
    // The mesh size follows the figures (files written before it was recorded have none): a cache
    // of another ref_div / conv_div is solved again, not reused under the wrong h.
    double cached_cell = cell;
    const bool read = static_cast<bool>(in >> r.energy >> r.dofs >> r.seconds);
    if (read && !(in >> cached_cell)) cached_cell = cell;
    if (field && read && std::abs(cached_cell - cell) <= 1e-9 * cell) {
      r.field = std::move(*field);
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
    // Before the first Newton step (the "meshed" report) there is no residual yet: print "-", as demnerf does.
    char residual[32] = "-";
    if (std::isfinite(p.residual)) std::snprintf(residual, sizeof residual, "%.2e", p.residual);
    std::fprintf(stderr, "    reference %s: load %.3f it %d residual %s, %.0f s\n", p.phase.c_str(), p.load_fraction,
                 p.iteration, residual, p.elapsed);
  };
  const auto start = std::chrono::steady_clock::now();
  try {
    const mechanics::SimulationOutcome out = mechanics::simulate(cloud, scenario, mechanics::SolverChoice::kFem, o);
    r.field = out.field;
    r.energy = out.energy;
    r.dofs = 3 * out.mesh_nodes;
    r.seconds = since(start);
    core::writeResult(ply, r.field);
    std::ofstream(figures) << std::setprecision(17) << r.energy << " " << r.dofs << " " << r.seconds << " " << cell
                          << "\n";
    std::fprintf(stderr, "  reference h=%g: %d dofs, %.1f s, energy %.6g\n", cell, r.dofs, r.seconds, r.energy);
  } catch (const std::exception& e) {
    r.error = e.what();
    r.seconds = since(start);
    std::fprintf(stderr, "  reference h=%g FAILED after %.1f s: %s\n", cell, r.seconds, e.what());
  }
  return r;
}

}  // namespace demnerf::bench
