// What body and load the default DEM solves on clouds sampled from a given surface (a NeRF
// extraction), against that surface and against the FEM reference's CGAL mesh of it (issue 13,
// item 2: the NeRF rows' energy errors). Per cloud: the particles' volume and area sums, the grid
// cell the sizing rules give and which rule set it, the cell quadrature's raw volume and second
// moments (on the T-bar also its stem's polar moment about z, the twist's axis), the inside test's
// misclassified volume, the loads' resultants, how much of a torque the sides carry and where each
// load's patch acts (the T-bar couple's two arms, DEM and FEM), and the held face's plane against the
// FEM's held nodes. No solve: each figure
// isolates one ingredient of the discrete problem (docs/mechanics_matrix_nerf_cuboid.md, "Why the
// energy still misses 1 %").
//
// Usage: mechanics_body_probe scenario=cuboid_twist mesh=SURFACE.ply [samplers=random,poisson,grid]
//          [spacings=6,10,15] [seed=1] [ref_h=0.005: also the CGAL TET mesh at this size]
//          [protect=1: protect every crease, the mesher before creasesAreNoise]
//          [probe_div=60: the inside test's lattice, smallest dimension / this] [config=FILE]

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/boundary_load_quadrature.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "demnerf/mechanics/surface_loads.hpp"
#include "dem_config_check.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_report.hpp"
#include "surface_roughness.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
namespace geo = demnerf::geometry;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

struct Moments {
  double volume = 0.0;
  Vector3d first = Vector3d::Zero();
  Matrix3d second = Matrix3d::Zero();  ///< integral of x x^T
  Matrix3d central() const {
    const Vector3d c = first / volume;
    return second - volume * c * c.transpose();
  }
};

// A tetrahedron's share: integral of x x^T is V / 20 (sum x_i x_i^T + s s^T), s the vertex sum.
void addTet(Moments& m, const Vector3d& a, const Vector3d& b, const Vector3d& c, const Vector3d& d) {
  const double v = (b - a).dot((c - a).cross(d - a)) / 6.0;
  const Vector3d s = a + b + c + d;
  m.volume += v;
  m.first += v * s / 4.0;
  m.second += v / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + d * d.transpose() + s * s.transpose());
}

Moments surfaceMoments(const core::TriangleMesh& mesh) {
  Moments m;
  for (const auto& f : mesh.faces)
    addTet(m, Vector3d::Zero(), mesh.vertices[f[0]], mesh.vertices[f[1]], mesh.vertices[f[2]]);
  if (m.volume < 0) m.volume = -m.volume, m.first = -m.first, m.second = -m.second;
  return m;
}

Moments tetMoments(const dm::TetMesh& mesh) {
  Moments m;
  for (const auto& e : mesh.elements) addTet(m, mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]);
  if (m.volume < 0) m.volume = -m.volume, m.first = -m.first, m.second = -m.second;
  return m;
}

// The torsion about the scenario's x axis sees the section's polar moment: yy + zz central moments.
double polar(const Moments& m) {
  const Matrix3d c = m.central();
  return c(1, 1) + c(2, 2);
}

void printAgainst(const char* what, const Moments& m, const Moments& surface) {
  std::printf("    %s: volume %.6g m^3 (%+.3f %% of the surface's), polar moment %+.3f %%\n", what, m.volume,
              100 * (m.volume / surface.volume - 1), 100 * (polar(m) / polar(surface) - 1));
}

// The T-bar twists its stem about z, which the x-axis polar moment above does not see: the stem's
// (z 10 .. 230 mm, away from the clamp and the junction) volume and polar moment about its own z axis,
// from the weights Newton integrates. Compare clouds on the same grid cell: the cut cells' points differ.
void printStemTorsion(const dm::CellQuadrature& q) {
  double v = 0.0, j = 0.0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  const auto inStem = [](const Vector3d& x) { return x(2) >= 0.01 && x(2) <= 0.23; };
  for (std::size_t p = 0; p < q.points.size(); ++p)
    if (inStem(q.points[p])) v += q.weights[p], c += q.weights[p] * q.points[p].head<2>();
  c /= v;
  for (std::size_t p = 0; p < q.points.size(); ++p)
    if (inStem(q.points[p])) j += q.weights[p] * (q.points[p].head<2>() - c).squaredNorm();
  std::printf("    stem (z 10 .. 230 mm): volume %.7g m^3, polar moment about z %.7g m^5\n", v, j);
}

// The grid DemSolver builds for this cloud (dem_solver.cpp): the resolved cell over the cloud's box
// with half a spacing of margin. Prints each sizing rule's candidate so the binding one shows.
dm::BsplineGrid demGrid(const core::ParticleCloud& cloud, const dm::DemConfig& config) {
  const dm::ResolvedDemConfig resolved = dm::resolvedDemConfig(config, cloud);
  double volume = 0.0, area = 0.0;
  for (double v : cloud.volumes) volume += std::max(v, 0.0);
  for (double a : cloud.areas) area += std::max(a, 0.0);
  const auto& g = config.grid;
  std::printf("    grid cell %.2f mm: body %.2f, spacings %.2f, thickness %.2f (4V/A %.2f mm), surface %.2f\n",
              1e3 * resolved.config.grid.cell, 1e3 * std::cbrt(volume / g.body_cells), 1e3 * 0.6 * resolved.spacing,
              g.thickness_cells > 0 ? 1e3 * 4 * volume / area / g.thickness_cells : 0.0, 4e3 * volume / area,
              g.surface_cells > 0 ? 1e3 * std::sqrt(area / g.surface_cells) : 0.0);
  const double surface_spacing = dm::surfaceParticleSpacing(cloud);
  for (double radius : {1e-2, 2e-2, 3 * surface_spacing})
    std::printf("    surface roughness at %.1f mm: %.3f mm (surface spacing %.2f mm)\n", 1e3 * radius,
                1e3 * dm::surfaceRoughness(cloud, radius), 1e3 * surface_spacing);
  Vector3d lo = cloud.positions[0], hi = lo;
  for (const Vector3d& p : cloud.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vector3d margin = Vector3d::Constant(0.5 * resolved.spacing);
  return dm::BsplineGrid(lo - margin, hi + margin, resolved.config.grid.cell, resolved.config.grid.degree);
}

// Lattice points the particles' inside test and the surface's disagree on, in % of the surface's volume.
void insideFigures(const core::ParticleCloud& cloud, const geo::InsideTest& exact, double step, double volume) {
  const dm::ParticleInsideTest test(cloud);
  Vector3d lo = cloud.positions[0], hi = lo;
  for (const Vector3d& p : cloud.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  lo -= Vector3d::Constant(2 * test.spacing());
  hi += Vector3d::Constant(2 * test.spacing());
  const Eigen::Vector3i n = ((hi - lo) / step).array().ceil().cast<int>();
  double false_in = 0, false_out = 0;
  for (int k = 0; k < n(2); ++k)
    for (int j = 0; j < n(1); ++j)
      for (int i = 0; i < n(0); ++i) {
        const Vector3d x = lo + step * (Vector3d(i, j, k) + Vector3d::Constant(0.5));
        const bool truth = exact.inside(x), said = test.inside(x);
        if (truth != said) (said ? false_in : false_out) += step * step * step;
      }
  std::printf("    inside test vs the surface: false inside %.3f %%, false outside %.3f %%\n", 100 * false_in / volume,
              100 * false_out / volume);
}

// Where a torque about x goes: the share on the sides (|y| or |z| above 45 mm, the strips of the
// cuboid's side faces inside the load's box) and the force-weighted mean x of the loaded points.
void printTorqueShare(const char* what, const std::vector<Vector3d>& points, const std::vector<Vector3d>& forces) {
  double all = 0.0, sides = 0.0, x = 0.0, weight = 0.0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const double m = points[k].cross(forces[k])(0);
    all += m;
    if (std::max(std::abs(points[k](1)), std::abs(points[k](2))) > 0.045) sides += m;
    x += forces[k].norm() * points[k](0), weight += forces[k].norm();
  }
  std::printf("    %s: %zu points, torque %.5g N m, %.2f %% of it on the sides, force-weighted x %.3f mm\n", what,
              points.size(), all, 100 * sides / all, 1e3 * x / weight);
}

// The FEM's load on the CGAL mesh (fem_assembly.cpp's setupLoads): the same spreadWrench over
// boundaryLoadQuadrature's points.
void printMeshLoads(const core::Scenario& scenario, const dm::TetMesh& tets) {
  const std::vector<dm::BoundaryFace> boundary = dm::boundaryFaces(tets);
  Vector3d moment = Vector3d::Zero();  // of all loads about the origin (the T-bar's couple)
  for (const core::Load& load : scenario.loads) {
    std::vector<Vector3d> points, forces;
    std::vector<double> weights;
    for (const dm::BoundaryLoadPoint& q : dm::boundaryLoadQuadrature(tets, boundary, load.region))
      points.push_back(q.x), weights.push_back(q.weight);
    const dm::WrenchTraction t = dm::spreadWrench(points, weights, load.force, load.torque, load.name);
    for (std::size_t q = 0; q < points.size(); ++q) {
      forces.push_back(weights[q] * t.at(points[q]));
      moment += points[q].cross(forces.back());
    }
    printTorqueShare(("load " + load.name + " (FEM)").c_str(), points, forces);
  }
  std::printf("    loads (FEM): M (%.5g %.5g %.5g) N m about the origin\n", moment(0), moment(1), moment(2));
}

void printLoads(const core::Scenario& scenario, const core::ParticleCloud& cloud, double step) {
  const dm::SurfaceLoads loads = dm::surfaceLoads(scenario, cloud, step);
  Vector3d force = Vector3d::Zero(), torque = Vector3d::Zero(), centroid = Vector3d::Zero();
  double weight = 0.0;
  for (std::size_t k = 0; k < loads.points.size(); ++k) {
    force += loads.forces[k];
    torque += loads.points[k].cross(loads.forces[k]);
    centroid += loads.forces[k].norm() * loads.points[k];
    weight += loads.forces[k].norm();
  }
  centroid /= std::max(weight, 1e-300);
  std::printf("    surface loads: %zu points, F (%.3g %.3g %.3g) N, M (%.5g %.5g %.5g) N m, |f|-weighted centre "
              "(%.2f %.2f %.2f) mm\n",
              loads.points.size(), force(0), force(1), force(2), torque(0), torque(1), torque(2), 1e3 * centroid(0),
              1e3 * centroid(1), 1e3 * centroid(2));
  printTorqueShare("loads (DEM)", loads.points, loads.forces);
  // Each load on its own: spreadWrench makes every patch's force and torque exact, so what the
  // surface changes is where a patch's force acts (the T-bar's couple: the two patches' arms).
  if (scenario.loads.size() < 2) return;
  for (const core::Load& load : scenario.loads) {
    core::Scenario one = scenario;
    one.loads = {load};
    const dm::SurfaceLoads patch = dm::surfaceLoads(one, cloud, step);
    printTorqueShare(("load " + load.name + " (DEM)").c_str(), patch.points, patch.forces);
  }
}

// The held face each fixture gets from the cloud: the DEM clamps this plane (clipped to the box).
void printHeldFaces(const core::Scenario& scenario, const core::ParticleCloud& cloud) {
  const std::vector<dm::HeldFace> faces = dm::heldFaces(scenario, cloud);
  for (std::size_t f = 0; f < faces.size(); ++f)
    std::printf("    fixture %zu (DEM): %s, point (%.3f %.3f %.3f) mm, normal (%.4f %.4f %.4f)\n", f,
                faces[f].valid ? "face" : "volume", 1e3 * faces[f].point(0), 1e3 * faces[f].point(1),
                1e3 * faces[f].point(2), faces[f].normal(0), faces[f].normal(1), faces[f].normal(2));
}

// The FEM's held nodes on the CGAL mesh (heldMeshNodes): where along each fixture's face normal
// they lie, against the DEM's plane.
void printMeshHeld(const core::Scenario& scenario, const dm::TetMesh& tets) {
  const std::vector<dm::BoundaryFace> boundary = dm::boundaryFaces(tets);
  for (std::size_t f = 0; f < scenario.fixtures.size(); ++f) {
    const std::vector<int> held = dm::heldMeshNodes(scenario.fixtures[f].region, tets, boundary);
    double lo = 1e300, hi = -1e300, mean = 0.0;
    for (int id : held) {
      lo = std::min(lo, tets.nodes[id](0)), hi = std::max(hi, tets.nodes[id](0));
      mean += tets.nodes[id](0) / static_cast<double>(held.size());
    }
    std::printf("    fixture %zu (FEM): %zu nodes held, x from %.3f to %.3f mm, mean %.3f mm\n", f, held.size(), 1e3 * lo,
                1e3 * hi, 1e3 * mean);
  }
}

void probeCloud(const core::ParticleCloud& cloud, const core::Scenario& scenario, const dm::DemConfig& config,
                const Moments& surface, const geo::InsideTest& inside, double probe_step) {
  double volume = 0.0, area = 0.0;
  std::size_t on_surface = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    volume += std::max(cloud.volumes[i], 0.0);
    area += std::max(cloud.areas[i], 0.0);
    on_surface += cloud.isSurface(i);
  }
  std::printf("    %zu surface particles; particle volumes %.6g m^3 (%+.3f %% of the surface's); areas %.5g m^2\n",
              on_surface, volume, 100 * (volume / surface.volume - 1), area);
  std::printf("    %zu rough surface particles (their faces' planes are blended)\n",
              dm::ParticleInsideTest(cloud).roughParticles());
  std::fflush(stdout);
  const dm::BsplineGrid grid = demGrid(cloud, config);
  dm::CellQuadratureConfig cq;
  cq.boundary_levels = config.grid.boundary_levels;
  cq.points_per_axis = config.grid.gauss_points;
  const dm::CellQuadrature q = dm::cellQuadrature(cloud, grid, cq);
  Moments m, raw;
  for (std::size_t p = 0; p < q.points.size(); ++p) {
    m.volume += q.weights[p];
    m.first += q.weights[p] * q.points[p];
    m.second += q.weights[p] * q.points[p] * q.points[p].transpose();
  }
  const double unscale = q.raw_volume / m.volume;
  raw.volume = m.volume * unscale, raw.first = m.first * unscale, raw.second = m.second * unscale;
  std::printf("    cell quadrature: %zu points\n", q.points.size());
  if (scenario.name == "tbar_twist") printStemTorsion(q);
  printAgainst("raw (the inside test's body)", raw, surface);
  printAgainst("scaled to the particles' volume (what Newton integrates)", m, surface);
  insideFigures(cloud, inside, probe_step, surface.volume);
  printLoads(scenario, cloud, grid.cell() / 8);
  printHeldFaces(scenario, cloud);
}

}  // namespace

int main(int argc, char** argv) {
  auto a = demnerf::bench::keyValueArguments(argc, argv);
  const auto text = [&](const std::string& k, const std::string& d) { return a.count(k) ? a[k] : d; };
  const std::string name = text("scenario", "cuboid_twist");
  demnerf::bench::MatrixCase mc;
  for (const auto& c : demnerf::bench::matrixCases())
    if (c.name == name) mc = c;
  if (mc.name.empty()) return std::fprintf(stderr, "unknown scenario %s\n", name.c_str()), 1;
  const core::Scenario scenario = core::loadScenario(std::string(DEMNERF_ROOT) + "/config/scenarios/" + name + ".yaml");
  const core::TriangleMesh mesh = a.count("mesh") ? core::readMesh(a["mesh"]) : mc.surface();
  const dm::DemConfig config = a.count("config") ? dm::loadSolverConfig(a["config"]).dem : dm::DemConfig{};
  const Moments surface = surfaceMoments(mesh);
  std::printf("%s: surface volume %.6g m^3, polar moment about the centroid's x axis %.6g m^5\n", name.c_str(),
              surface.volume, polar(surface));
  if (a.count("ref_h")) {
    dm::CgalMeshConfig cgal;
    cgal.cell = std::stod(a["ref_h"]);
    cgal.order = 1;
    // protect=1: every crease as a sharp edge, as the mesher did before creasesAreNoise (the cached
    // NeRF T-bar reference of docs/mechanics_matrix_nerf_tbar.md was meshed so).
    if (text("protect", "0") == "1") cgal.max_dangling_fraction = 1.0;
    const dm::TetMesh tets = dm::cgalMeshFromSurface(mesh, cgal);
    std::printf("  CGAL mesh at h %.4g m (%zu tetrahedra; the reference FEM's, straight-sided):\n", cgal.cell,
                tets.elements.size());
    printAgainst("CGAL mesh", tetMoments(tets), surface);
    printMeshHeld(scenario, tets);
    printMeshLoads(scenario, tets);
  }
  const geo::InsideTest inside(mesh);
  const double probe_step = mc.smallest / std::stod(text("probe_div", "60"));
  for (const std::string& sampler : demnerf::bench::splitList(text("samplers", "random,poisson,grid")))
    for (const std::string& div : demnerf::bench::splitList(text("spacings", "6,10,15"))) {
      geo::SamplerConfig sc;
      sc.method = geo::parseSamplingMethod(sampler);
      sc.spacing = mc.smallest / std::stod(div);
      sc.seed = std::stoull(text("seed", "1"));
      const core::ParticleCloud cloud = geo::sampleParticles(mesh, sc);
      std::printf("  %s 1/%s: %zu particles\n", sampler.c_str(), div.c_str(), cloud.size());
      probeCloud(cloud, scenario, config, surface, inside, probe_step);
    }
  return 0;
}
