// T-bar twist with the FEM baseline: mesh convergence of structured TET4 / TET10 voxel meshes of
// the exact T-bar, and the converged reference that bench/mechanics_dem (case=tbar) compares to.
// Usage: mechanics_tbar_fem key=value ...
//   mode=converge (default): orders=2 (1, 2 or 12) hs=0.02,0.015,0.01,0.0075 particle_h=0.0075
//        ref_out=PATH (the finest level at the particles, a result PLY; default: none written)
//        scenario=PATH threads=N verbose=0|1 reuse=CG_ITS (FemConfig::reuse_factorisation_iterations, both modes) patch_inner=X (load patches from |x| = X, a study
//        variant whose patch edge is a grid line of every level)
//        mesher=voxel|cgal (cgal: CGAL Mesh_3 tetrahedra of edge h of the T-bar's union surface)
//        ref=PATH (also give each level's rel L2 against this result PLY at the same particles,
//        e.g. bench/data/tbar_twist_fem_reference.ply)
//   mode=speed: the CLI's `demnerf simulate --solver fem --order 1` on the 6 mm grid particles
//        (voxels from the particles), reps=3 order=1 cell=0.006 [particles=P.ply] [ordering=amd]
//        [reuse=CG_ITS] [steps=N] -> median seconds.
// Every level is interpolated to the same grid particles (bench/mechanics_bench_common.hpp), and
// the table gives the relative L2 difference of each level to the finest one there.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"
#include "mechanics_bench_common.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;
using demnerf::bench::median;
using demnerf::bench::since;
using demnerf::bench::tbarParticles;

namespace {

std::vector<double> parseList(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(std::atof(item.c_str()));
  return out;
}

// The T-bar as ONE closed two-manifold surface (what CGAL's mesher needs; the two touching boxes
// above are not one): the boundary faces of the 4 boxes of the grid x {-0.15, -0.03, 0.03, 0.15},
// y {-0.03, 0.03}, z {0, 0.24, 0.30} that the body fills (the leg, three bar segments), each face
// split into two outward triangles; shared grid corners make it conforming (no T-junctions).
core::TriangleMesh tbarUnionSurface() {
  const double xs[] = {-0.15, -0.03, 0.03, 0.15}, ys[] = {-0.03, 0.03}, zs[] = {0.0, 0.24, 0.30};
  auto filled = [](int i, int j, int k) {
    if (i < 0 || i > 2 || j != 0 || k < 0 || k > 1) return false;
    return k == 1 || i == 1;
  };
  core::TriangleMesh m;
  std::map<std::array<int, 3>, int> id;
  auto vertex = [&](std::array<int, 3> g) {
    auto it = id.find(g);
    if (it != id.end()) return it->second;
    m.vertices.emplace_back(xs[g[0]], ys[g[1]], zs[g[2]]);
    return id[g] = static_cast<int>(m.vertices.size()) - 1;
  };
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 2; ++k) {
      if (!filled(i, 0, k)) continue;
      for (int axis = 0; axis < 3; ++axis)
        for (int side : {0, 1}) {
          std::array<int, 3> n{i, 0, k};
          n[axis] += side ? 1 : -1;
          if (filled(n[0], n[1], n[2])) continue;
          // The face's corners in counter-clockwise order seen from outside.
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;
          std::array<int, 3> c{i, 0, k};
          c[axis] += side;
          std::array<int, 4> q;
          const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
          for (int r = 0; r < 4; ++r) {
            std::array<int, 3> g = c;
            g[u] += du[r];
            g[v] += dv[r];
            q[r] = vertex(g);
          }
          if (side == 0) std::swap(q[1], q[3]);
          m.faces.push_back({q[0], q[1], q[2]});
          m.faces.push_back({q[0], q[2], q[3]});
        }
    }
  return m;
}

using Arguments = std::map<std::string, std::string>;

std::string text(const Arguments& a, const char* key, const std::string& fallback) {
  const auto it = a.find(key);
  return it != a.end() ? it->second : fallback;
}

double number(const Arguments& a, const char* key, double fallback) {
  const auto it = a.find(key);
  return it != a.end() ? std::atof(it->second.c_str()) : fallback;
}

/// The twist scenario; patch_inner=X is a study variant with load patches from |x| = X to the bar
/// ends. The scenario's |x| = 0.10 is a grid line only for h = 0.01, 0.005; 0.09 is one for 0.02,
/// 0.015, 0.01, 0.0075, 0.005, so all levels then solve the same load.
core::Scenario twistScenario(const Arguments& a) {
  core::Scenario scenario =
      core::loadScenario(text(a, "scenario", std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml"));
  if (a.count("patch_inner")) {
    const double inner = number(a, "patch_inner", 0.10);
    for (core::Load& load : scenario.loads) {
      const double sign = load.region.center.x() > 0 ? 1.0 : -1.0;
      load.region.center.x() = sign * 0.5 * (inner + 0.15);
      load.region.size.x() = 0.15 - inner;
    }
  }
  return scenario;
}

/// mode=speed: what `demnerf simulate --particles P --scenario tbar_twist.yaml --solver fem
/// --order 1` does (mechanics::simulate's FEM branch, inlined so the timing is of exactly these
/// steps: particle voxels, solve, interpolate to the particles).
void runSpeed(const Arguments& a, const core::Scenario& scenario, dm::FemConfig fem_config) {
  const core::ParticleCloud cloud =
      a.count("particles") ? core::readParticles(a.at("particles")) : tbarParticles(number(a, "cell", 0.006));
  if (text(a, "ordering", "") == "amd") fem_config.ordering = dm::FemConfig::Ordering::kAmd;
  if (a.count("steps")) fem_config.load_steps = static_cast<int>(number(a, "steps", 0));
  dm::VoxelMeshConfig voxel;
  voxel.order = static_cast<int>(number(a, "order", 1));
  std::vector<double> seconds;
  for (int rep = 0; rep < static_cast<int>(number(a, "reps", 3)); ++rep) {
    const auto start = std::chrono::steady_clock::now();
    dm::FemSolver fem(dm::voxelMeshFromParticles(cloud, voxel), scenario, fem_config);
    const dm::FemResult& r = fem.solve();
    const dm::PointField at = fem.interpolate(cloud.positions);
    seconds.push_back(since(start));
    double max_u = 0;
    for (const auto& u : at.displacement) max_u = std::max(max_u, u.norm());
    std::printf("run %d: %zu particles, %zu nodes, %zu elements, %.2f s (Newton its %d, factorisations %d, CG its %d), energy %.6g J, max |u| %.3f mm\n",
                rep + 1, cloud.size(), fem.mesh().nodes.size(), fem.mesh().elements.size(), seconds.back(),
                r.newton_iterations, r.factorisations, r.cg_iterations, r.energy, 1e3 * max_u);
  }
  std::printf("median %.2f s over %zu runs\n", median(seconds), seconds.size());
}

struct Level {
  int order;
  double h;
  std::size_t elements, dofs;
  double seconds, energy, max_u;
  int newton;
  std::vector<Vector3d> u;  // at the particles
  std::vector<double> von_mises;
  Vector3d patch[2];
};

/// One mesh level: mesh (voxels or CGAL) of element order and size h, solve, and the answer at
/// the particles and at the two patch points.
Level solveLevel(const core::TriangleMesh& surface, bool cgal, int order, double h, const core::Scenario& scenario,
                 const dm::FemConfig& fem_config, const core::ParticleCloud& cloud) {
  const std::vector<Vector3d> patches = {Vector3d(0.125, -0.03, 0.27), Vector3d(-0.125, 0.03, 0.27)};
  dm::VoxelMeshConfig voxel;
  voxel.cell = h;
  voxel.order = order;
  const auto start = std::chrono::steady_clock::now();
  dm::CgalMeshConfig cgal_config;
  cgal_config.cell = h;
  cgal_config.order = order;
  dm::FemSolver fem(cgal ? dm::cgalMeshFromSurface(surface, cgal_config) : dm::voxelMeshFromSurface(surface, voxel),
                    scenario, fem_config);
  const dm::FemResult& r = fem.solve();
  Level level;
  level.seconds = since(start);
  level.order = order;
  level.h = h;
  level.elements = fem.mesh().elements.size();
  level.dofs = 3 * fem.mesh().nodes.size();
  level.energy = r.energy;
  level.newton = r.newton_iterations;
  level.max_u = 0;
  for (const auto& u : r.displacement) level.max_u = std::max(level.max_u, u.norm());
  const dm::PointField at = fem.interpolate(cloud.positions);
  level.u = at.displacement;
  level.von_mises = at.von_mises;
  const auto p = fem.interpolate(patches).displacement;
  level.patch[0] = p[0];
  level.patch[1] = p[1];
  std::fprintf(stderr, "TET%d h=%g: %zu elements, %zu dofs, %.1f s, %d Newton its\n", order == 1 ? 4 : 10, h,
               level.elements, level.dofs, level.seconds, level.newton);
  return level;
}

/// The table of the levels, each against the finest one (the most dofs).
void printConvergence(const std::vector<Level>& levels, const Level& finest, std::size_t particles, double particle_h) {
  double ref_norm = 0;
  for (const auto& u : finest.u) ref_norm += u.squaredNorm();
  std::printf("T-bar twist, %zu grid particles (h = %g m); rel L2 = ||u - u_finest|| / ||u_finest|| at the particles\n",
              particles, particle_h);
  std::printf("| element | h (m) | elements | dofs | seconds | Newton its | max |u| (mm) | |u| patch +x (mm) | |u| patch -x (mm) | energy (J) | rel L2 vs finest |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const Level& l : levels) {
    double e = 0;
    for (std::size_t i = 0; i < l.u.size(); ++i) e += (l.u[i] - finest.u[i]).squaredNorm();
    std::printf("| TET%d | %g | %zu | %zu | %.1f | %d | %.3f | %.3f | %.3f | %.6g | %.2e |\n", l.order == 1 ? 4 : 10, l.h,
                l.elements, l.dofs, l.seconds, l.newton, 1e3 * l.max_u, 1e3 * l.patch[0].norm(), 1e3 * l.patch[1].norm(),
                l.energy, std::sqrt(e / ref_norm));
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Arguments a = demnerf::bench::keyValueArguments(argc, argv);
  const core::Scenario scenario = twistScenario(a);
  dm::FemConfig fem_config;
  fem_config.threads = static_cast<int>(number(a, "threads", 0));
  fem_config.verbose = number(a, "verbose", 0) != 0;
  if (a.count("reuse")) fem_config.reuse_factorisation_iterations = static_cast<int>(number(a, "reuse", 30));
  if (text(a, "mode", "converge") == "speed") {
    runSpeed(a, scenario, fem_config);
    return 0;
  }

  const core::ParticleCloud cloud = tbarParticles(number(a, "particle_h", 0.0075));
  const bool cgal = text(a, "mesher", "voxel") == "cgal";
  const core::TriangleMesh surface = cgal ? tbarUnionSurface() : demnerf::bench::tbarSurface();
  core::ResultField reference;
  if (a.count("ref")) reference = core::readResult(a.at("ref"));
  if (!reference.displacements.empty() && reference.size() != cloud.size()) {
    std::fprintf(stderr, "ref has %zu rows, the particles %zu: use the particle_h it was written with\n",
                 reference.size(), cloud.size());
    return 1;
  }
  std::vector<int> orders;
  for (char c : text(a, "orders", "2"))
    if (c == '1' || c == '2') orders.push_back(c - '0');
  std::vector<Level> levels;
  for (int order : orders)
    for (double h : parseList(text(a, "hs", "0.02,0.015,0.01,0.0075"))) {
      levels.push_back(solveLevel(surface, cgal, order, h, scenario, fem_config, cloud));
      const Level& level = levels.back();
      if (reference.displacements.empty()) continue;
      double e = 0, r = 0;
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        e += (level.u[i] - reference.displacements[i]).squaredNorm();
        r += reference.displacements[i].squaredNorm();
      }
      std::printf("%s TET%d h=%g: %zu elements, %zu dofs, %.1f s (mesh + solve), rel L2 vs %s: %.3e\n",
                  cgal ? "cgal" : "voxel", order == 1 ? 4 : 10, h, level.elements, level.dofs, level.seconds,
                  a.at("ref").c_str(), std::sqrt(e / r));
    }
  if (levels.empty()) return 0;
  const Level& finest = *std::max_element(levels.begin(), levels.end(),
                                          [](const Level& x, const Level& y) { return x.dofs < y.dofs; });
  printConvergence(levels, finest, cloud.size(), number(a, "particle_h", 0.0075));
  if (a.count("ref_out")) {
    core::ResultField result;
    result.positions = cloud.positions;
    result.displacements = finest.u;
    result.von_mises = finest.von_mises;
    core::writeResult(a.at("ref_out"), result);
    std::printf("wrote the TET%d h = %g result at the %zu particles to %s\n", finest.order == 1 ? 4 : 10, finest.h,
                cloud.size(), a.at("ref_out").c_str());
  }
  return 0;
}
