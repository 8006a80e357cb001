// Where the CGAL reference mesh of a surface spends its size and time (issue 13, the NeRF cuboid):
// the sharp creases it would protect, the tetrahedra it makes at mesh size `cell`, and the CPU
// seconds of meshing, of locating points in the mesh and (solve=1) of the TET10 solve.
// With surface_of=P.ply instead of mesh=, the surface is the one the cloud's surface particles
// describe (surfaceOfParticles every `step` m, default cell / 3, as the FEM builds it for a cloud
// without --mesh; sharpen=0: its edges left chamfered), written to write=M.ply when asked, with its
// CPU seconds; protect=1 protects its creases as the mesher does a given surface's.
//   mechanics_cgal_probe mesh=SURFACE.ply|surface_of=P.ply cell=0.0167 [step=S] [sharpen=1] [protect=0] [write=M.ply]
//       [facet_distance=M] [angle=60] [max_dangling=0.25] [particles=P.ply] [scenario=S.yaml solve=0|1]
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/particle_surface.hpp"
#include "demnerf/mechanics/sharp_features.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;

namespace {
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }
}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IONBF, 0);  // lines before a crash or a kill still show
  std::map<std::string, std::string> a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto eq = s.find('=');
    if (eq != std::string::npos) a[s.substr(0, eq)] = s.substr(eq + 1);
  }
  const auto num = [&](const char* k, double d) { return a.count(k) ? std::stod(a[k]) : d; };
  dm::CgalMeshConfig config;
  config.cell = num("cell", 0.0);
  core::TriangleMesh surface;
  if (a.count("surface_of")) {
    const double t0 = cpuSeconds();
    surface = dm::surfaceOfParticles(core::readParticles(a["surface_of"]), num("step", config.cell / 3.0),
                                     num("sharpen", 1) > 0);
    std::printf("surface of the particles: %zu faces, %.2f CPU s\n", surface.faces.size(), cpuSeconds() - t0);
    if (a.count("write")) core::writeMesh(a["write"], surface);
    config.protect_creases = num("protect", 0) > 0;  // off: as the FEM meshes it
  } else {
    surface = core::readMesh(a.at("mesh"));
  }
  config.facet_distance = num("facet_distance", config.facet_distance);
  config.feature_angle = num("angle", config.feature_angle);
  config.max_dangling_fraction = num("max_dangling", config.max_dangling_fraction);
  std::vector<dm::SharpCurve> curves = dm::sharpCurves(surface, config.feature_angle);
  std::sort(curves.begin(), curves.end(), [](const auto& x, const auto& y) { return x.length < y.length; });
  double total = 0, dangling = 0;
  for (const auto& c : curves) {
    total += c.length;
    if (c.dangling) dangling += c.length;
  }
  std::printf("surface: %zu faces; %zu sharp curves (angle %g), total %.1f mm", surface.faces.size(), curves.size(),
              config.feature_angle, total * 1e3);
  if (!curves.empty())
    std::printf(", length median %.2f mm, max %.1f mm", curves[curves.size() / 2].length * 1e3, curves.back().length * 1e3);
  std::printf("; dangling %.1f mm; protected: %s\n", dangling * 1e3,
              config.protect_creases && !dm::creasesAreNoise(surface, config) ? "all" : "none");
  double t = cpuSeconds();
  const dm::TetMesh mesh = dm::cgalMeshFromSurface(surface, config);
  std::printf("mesh: cell %g m: %zu tets, %zu nodes (%zu dofs), %.1f CPU s\n", config.cell, mesh.elements.size(),
              mesh.nodes.size(), 3 * mesh.nodes.size(), cpuSeconds() - t);
  if (!a.count("scenario")) return 0;
  const core::Scenario scenario = core::loadScenario(a["scenario"]);
  t = cpuSeconds();
  dm::FemSolver fem(mesh, scenario);
  std::printf("fem setup: %.1f CPU s\n", cpuSeconds() - t);
  if (num("solve", 0) > 0) {
    t = cpuSeconds();
    const dm::FemResult& r = fem.solve();
    std::printf("fem solve: energy %.6g J, %.1f CPU s\n", r.energy, cpuSeconds() - t);
  }
  if (a.count("particles")) {
    const core::ParticleCloud cloud = core::readParticles(a["particles"]);
    t = cpuSeconds();
    const dm::PointField at = fem.interpolate(cloud.positions);
    std::printf("interpolate at %zu points: %.2f CPU s\n", cloud.size(), cpuSeconds() - t);
  }
  return 0;
}
