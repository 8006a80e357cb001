// What the default DEM's discrete problem makes of one matrix cloud, term by term, against the
// exact surface (issue 13, item 2: per-sampler energy errors): the cell quadrature's volume and
// second moments, the applied load's resultant and moments, the held faces, and the inside test's
// misclassified volume near the surface. No solve: each figure isolates one ingredient.
//
// Usage: mechanics_quadrature_probe scenario=cuboid_twist samplers=random,poisson,grid spacings=6,10,15
//          seed=1 probe_div=60 (the inside test's lattice: smallest dimension / probe_div)

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"
#include "demnerf/mechanics/surface_loads.hpp"
#include "mechanics_matrix_cases.hpp"

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
};

// Exact volume moments of a closed, outward mesh: signed tetrahedra from the origin.
Moments meshMoments(const core::TriangleMesh& mesh) {
  Moments m;
  for (const auto& f : mesh.faces) {
    const Vector3d a = mesh.vertices[f[0]], b = mesh.vertices[f[1]], c = mesh.vertices[f[2]];
    const double v = a.dot(b.cross(c)) / 6.0;
    m.volume += v;
    m.first += v * (a + b + c) / 4.0;
    const Vector3d s = a + b + c;
    m.second += v / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  if (m.volume < 0) {
    m.volume = -m.volume;
    m.first = -m.first;
    m.second = -m.second;
  }
  return m;
}

Moments quadratureMoments(const std::vector<Vector3d>& points, const std::vector<double>& weights) {
  Moments m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    m.volume += weights[i];
    m.first += weights[i] * points[i];
    m.second += weights[i] * points[i] * points[i].transpose();
  }
  return m;
}

// The default DEM's grid for a cloud, as DemSolver builds it (dem_solver.cpp, dem_config_check.cpp).
dm::BsplineGrid demGrid(const core::ParticleCloud& cloud) {
  const dm::DemConfig config;
  std::vector<double> volumes;
  double volume = 0.0;
  for (double v : cloud.volumes)
    if (v > 0) volumes.push_back(v), volume += v;
  const auto at = volumes.begin() + static_cast<long>(0.9 * (volumes.size() - 1));
  std::nth_element(volumes.begin(), at, volumes.end());
  const double spacing = std::cbrt(*at);
  const double cell = std::max(std::cbrt(volume / config.grid.body_cells), 0.6 * spacing);
  Vector3d lo = cloud.positions[0], hi = lo;
  for (const Vector3d& p : cloud.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vector3d margin = Vector3d::Constant(0.5 * spacing);
  return dm::BsplineGrid(lo - margin, hi + margin, cell, config.grid.degree);
}

// The grid's load vector: each basis function's share of the forces, per component.
Eigen::MatrixXd loadVector(const dm::BsplineGrid& grid, const std::vector<Vector3d>& points,
                           const std::vector<Vector3d>& forces) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(grid.nodeCount(), 3);
  std::vector<long> nodes(grid.supportSize());
  std::vector<double> values(grid.supportSize());
  std::vector<Vector3d> gradients(grid.supportSize());
  for (std::size_t k = 0; k < points.size(); ++k) {
    grid.evaluate(points[k], nodes.data(), values.data(), gradients.data());
    for (int a = 0; a < grid.supportSize(); ++a) out.row(nodes[a]) += values[a] * forces[k].transpose();
  }
  return out;
}

void particleLoads(const core::Scenario& scenario, const core::ParticleCloud& cloud, std::vector<Vector3d>& points,
                   std::vector<Vector3d>& forces) {
  const std::vector<Vector3d> t = dm::particleTractions(scenario, cloud);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.areas[i] > 0 && t[i].squaredNorm() > 0) {
      points.push_back(cloud.positions[i]);
      forces.push_back(cloud.areas[i] * t[i]);
    }
}

// Resultants of the loads at points, and their load vector on the grid against a reference's.
void printLoads(const char* what, const dm::BsplineGrid& grid, const std::vector<Vector3d>& points,
                const std::vector<Vector3d>& forces, const Eigen::MatrixXd& reference) {
  Vector3d force = Vector3d::Zero(), torque = Vector3d::Zero();
  for (std::size_t k = 0; k < points.size(); ++k) {
    force += forces[k];
    torque += points[k].cross(forces[k]);
  }
  const double apart = (loadVector(grid, points, forces) - reference).norm() / reference.norm();
  std::printf("  %s: %zu points, F (%.4g %.4g %.4g) M about 0 (%.5g %.5g %.5g); load vector on the grid %.2f %% "
              "from the reference\n",
              what, points.size(), force(0), force(1), force(2), torque(0), torque(1), torque(2), 100 * apart);
}

// Volume the inside test gets wrong on a lattice over the body's box (+ 2 spacings): false inside
// and false outside, each split into points within `edge_band` of two box sides (edges) or not.
void insideFigures(const core::ParticleCloud& cloud, const geo::InsideTest& exact, double step, double exact_volume) {
  dm::ParticleInsideTest test(cloud);
  Vector3d lo = cloud.positions[0], hi = lo;
  for (const Vector3d& p : cloud.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double pad = 2 * test.spacing();
  const Eigen::Vector3i n = ((hi - lo + Vector3d::Constant(2 * pad)) / step).array().ceil().cast<int>();
  double false_in[2] = {0, 0}, false_out[2] = {0, 0};
  const double cube = step * step * step;
  for (int k = 0; k < n(2); ++k)
    for (int j = 0; j < n(1); ++j)
      for (int i = 0; i < n(0); ++i) {
        const Vector3d x = lo - Vector3d::Constant(pad) + step * (Vector3d(i, j, k) + Vector3d::Constant(0.5));
        const bool truth = exact.inside(x), said = test.inside(x);
        if (truth == said) continue;
        int near_sides = 0;
        for (int a = 0; a < 3; ++a)
          near_sides += std::min(std::abs(x(a) - lo(a)), std::abs(x(a) - hi(a))) < test.spacing();
        (said ? false_in : false_out)[near_sides >= 2] += cube;
      }
  std::printf("  inside test: false inside %.3f %% (faces %.3f, edges %.3f), false outside %.3f %% (faces %.3f, edges %.3f)\n",
              100 * (false_in[0] + false_in[1]) / exact_volume, 100 * false_in[0] / exact_volume,
              100 * false_in[1] / exact_volume, 100 * (false_out[0] + false_out[1]) / exact_volume,
              100 * false_out[0] / exact_volume, 100 * false_out[1] / exact_volume);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

struct Probe {
  std::string name;
  core::Scenario scenario;
  core::TriangleMesh mesh;
  Moments exact;
  Vector3d centroid;
  Matrix3d central;
  double smallest = 0.0, probe_step = 0.0;
  core::ParticleCloud fine;  ///< the loads' reference: a grid cloud at 1/40, its surface loads at cell / 32
};

void printQuadrature(const Probe& pr, const core::ParticleCloud& cloud, const dm::BsplineGrid& grid,
                     const geo::InsideTest& inside) {
  dm::CellQuadratureConfig cq;
  cq.boundary_levels = dm::DemConfig().grid.boundary_levels;
  const dm::CellQuadrature q = dm::cellQuadrature(cloud, grid, cq);
  const Moments m = quadratureMoments(q.points, q.weights);
  const Vector3d qc = m.first / m.volume;
  const Matrix3d qcentral = m.second - m.volume * qc * qc.transpose();
  double outside = 0.0;
  for (std::size_t p = 0; p < q.points.size(); ++p)
    if (!inside.inside(q.points[p])) outside += q.weights[p];
  std::printf("  cell quadrature (cell %.4g m): %zu points; raw volume %+.3f %%, weight outside the body %.3f %%; "
              "centroid shift (%.1e %.1e %.1e) m; central second moments xx %+.3f yy %+.3f zz %+.3f %%\n",
              grid.cell(), q.points.size(), 100 * (q.raw_volume / pr.exact.volume - 1), 100 * outside / pr.exact.volume,
              qc(0) - pr.centroid(0), qc(1) - pr.centroid(1), qc(2) - pr.centroid(2),
              100 * (qcentral(0, 0) / pr.central(0, 0) - 1), 100 * (qcentral(1, 1) / pr.central(1, 1) - 1),
              100 * (qcentral(2, 2) / pr.central(2, 2) - 1));
}

void probeCloud(const Probe& pr, const core::ParticleCloud& cloud, const geo::InsideTest& inside) {
  const dm::BsplineGrid grid = demGrid(cloud);
  printQuadrature(pr, cloud, grid, inside);
  const dm::SurfaceLoads reference = dm::surfaceLoads(pr.scenario, pr.fine, grid.cell() / 32);
  const Eigen::MatrixXd ref = loadVector(grid, reference.points, reference.forces);
  std::vector<Vector3d> points, forces;
  particleLoads(pr.scenario, cloud, points, forces);
  printLoads("loads on the particles", grid, points, forces, ref);
  const dm::SurfaceLoads surface = dm::surfaceLoads(pr.scenario, cloud, grid.cell() / 8);
  printLoads("loads on the surface", grid, surface.points, surface.forces, ref);
  const std::vector<dm::HeldFace> faces = dm::heldFaces(pr.scenario, cloud);
  for (std::size_t f = 0; f < faces.size(); ++f)
    std::printf("  fixture %zu: %s, point (%.5f %.5f %.5f) normal (%.4f %.4f %.4f); %zu particles held in all\n", f,
                faces[f].valid ? "a face" : "a volume", faces[f].point(0), faces[f].point(1), faces[f].point(2),
                faces[f].normal(0), faces[f].normal(1), faces[f].normal(2),
                dm::resolveHeldParticles(pr.scenario, cloud, faces).index.size());
  insideFigures(cloud, inside, pr.probe_step, pr.exact.volume);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto eq = a.find('=');
    if (eq != std::string::npos) args[a.substr(0, eq)] = a.substr(eq + 1);
  }
  const auto text = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  Probe pr;
  pr.name = text("scenario", "cuboid_twist");
  demnerf::bench::MatrixCase mc;
  for (const auto& c : demnerf::bench::matrixCases())
    if (c.name == pr.name) mc = c;
  if (mc.name.empty()) return std::fprintf(stderr, "unknown scenario %s\n", pr.name.c_str()), 1;
  pr.scenario = core::loadScenario(std::string(DEMNERF_ROOT) + "/config/scenarios/" + pr.name + ".yaml");
  pr.mesh = mc.surface();
  pr.exact = meshMoments(pr.mesh);
  pr.centroid = pr.exact.first / pr.exact.volume;
  pr.central = pr.exact.second - pr.exact.volume * pr.centroid * pr.centroid.transpose();
  pr.smallest = mc.smallest;
  pr.probe_step = mc.smallest / std::stod(text("probe_div", "60"));
  geo::SamplerConfig fine;
  fine.method = geo::SamplingMethod::kGrid;
  fine.spacing = mc.smallest / 40;
  pr.fine = geo::sampleParticles(pr.mesh, fine);
  const geo::InsideTest inside(pr.mesh);
  std::printf("%s: exact volume %.6g\n", pr.name.c_str(), pr.exact.volume);
  for (const std::string& sampler : split(text("samplers", "random,poisson,grid")))
    for (const std::string& div : split(text("spacings", "6,10,15"))) {
      geo::SamplerConfig config;
      config.method = geo::parseSamplingMethod(sampler);
      config.spacing = mc.smallest / std::stod(div);
      config.seed = std::stoull(text("seed", "1"));
      const core::ParticleCloud cloud = geo::sampleParticles(pr.mesh, config);
      std::printf("%s 1/%s: %zu particles\n", sampler.c_str(), div.c_str(), cloud.size());
      probeCloud(pr, cloud, inside);
    }
  return 0;
}
