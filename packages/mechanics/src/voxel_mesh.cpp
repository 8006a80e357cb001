#include "demnerf/mechanics/voxel_mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <unordered_map>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

// The ray of a column is moved off the grid by an irrational fraction of a cell so it does not
// pass exactly through the edges and vertices of box-like meshes (whose faces lie on cell planes).
constexpr double kRayOffsetY = 0.3183098861837907e-4;
constexpr double kRayOffsetZ = 0.1414213562373095e-4;

// x of the crossing of the ray {(t, y, z)} with triangle abc, or NaN when it misses.
double crossing(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, double y, double z) {
  // 2D barycentric coordinates of (y, z) in the triangle projected on the yz plane.
  const double d = (b.y() - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (b.z() - a.z());
  if (d == 0.0) return std::nan("");
  const double l1 = ((y - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (z - a.z())) / d;
  const double l2 = ((b.y() - a.y()) * (z - a.z()) - (y - a.y()) * (b.z() - a.z())) / d;
  const double l0 = 1.0 - l1 - l2;
  if (l0 < 0 || l1 < 0 || l2 < 0) return std::nan("");
  return l0 * a.x() + l1 * b.x() + l2 * c.x();
}

// Grid of active cells -> conforming Kuhn tetrahedra (the split of structuredMesh).
TetMesh tetsFromCells(const Eigen::Vector3d& lower, const Eigen::Vector3d& h, const Eigen::Vector3i& dims,
                      const std::vector<char>& active, int order) {
  if (order != 1 && order != 2) throw core::Error("voxel meshes support tetrahedra of order 1 or 2, not " + std::to_string(order));
  TetMesh mesh;
  std::unordered_map<long long, int> node_id;
  const long long nx = dims(0) + 1, ny = dims(1) + 1;
  auto node = [&](const Eigen::Vector3i& v) {
    const long long key = v(0) + nx * (v(1) + ny * static_cast<long long>(v(2)));
    auto it = node_id.find(key);
    if (it != node_id.end()) return it->second;
    const int id = static_cast<int>(mesh.nodes.size());
    mesh.nodes.push_back(lower + v.cast<double>().cwiseProduct(h));
    node_id.emplace(key, id);
    return id;
  };
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < dims(2); ++k)
    for (int j = 0; j < dims(1); ++j)
      for (int i = 0; i < dims(0); ++i) {
        if (!active[i + dims(0) * (j + static_cast<std::size_t>(dims(1)) * k)]) continue;
        for (const auto& p : perms) {
          Eigen::Vector3i v(i, j, k);
          std::array<int, 10> e;
          e.fill(-1);
          e[0] = node(v);
          for (int s = 0; s < 3; ++s) {
            v(p[s]) += 1;
            e[s + 1] = node(v);
          }
          double volume = 0;
          barycentricGradients({mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]}, &volume);
          if (volume < 0) std::swap(e[1], e[2]);
          mesh.elements.push_back(e);
        }
      }
  if (mesh.elements.empty()) throw core::Error("voxel mesh: no cell lies inside the body; use a smaller cell size");
  return order == 2 ? elevateToQuadratic(mesh) : mesh;
}

void checkCell(double cell) {
  if (!(cell > 0.0) || !std::isfinite(cell))
    throw core::Error("voxel mesh: the cell size must be a positive length, got " + std::to_string(cell));
}

}  // namespace

bool insideSurface(const core::TriangleMesh& mesh, const Eigen::Vector3d& point) {
  if (mesh.vertices.empty()) return false;
  Eigen::Vector3d lo = mesh.vertices[0], hi = lo;
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  // Off the edges of the triangulation by a tiny irrational amount (see kRayOffsetY).
  const double scale = 1e-3 * (hi - lo).norm();
  const double y = point.y() + kRayOffsetY * scale, z = point.z() + kRayOffsetZ * scale;
  int crossings = 0;
  for (const auto& f : mesh.faces) {
    const double x = crossing(mesh.vertices[f[0]], mesh.vertices[f[1]], mesh.vertices[f[2]], y, z);
    if (x > point.x()) ++crossings;
  }
  return crossings % 2 == 1;
}

TetMesh voxelMeshFromSurface(const core::TriangleMesh& mesh, const VoxelMeshConfig& config) {
  if (mesh.faces.empty() || mesh.vertices.empty()) throw core::Error("voxel mesh: the surface mesh has no faces");
  checkCell(config.cell);
  Eigen::Vector3d lo = mesh.vertices[0], hi = lo;
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  Eigen::Vector3i dims;
  Eigen::Vector3d h;
  for (int a = 0; a < 3; ++a) {
    dims(a) = std::max(1, static_cast<int>(std::lround((hi(a) - lo(a)) / config.cell)));
    h(a) = (hi(a) - lo(a)) / dims(a);
  }
  if (static_cast<double>(dims.prod()) > 2e7)
    throw core::Error("voxel mesh: cell size " + std::to_string(config.cell) + " gives too many cells; use a larger one");
  // One ray per (y, z) column of cell centres; the crossings of each column decide all its cells.
  std::vector<std::vector<double>> hits(static_cast<std::size_t>(dims(1)) * dims(2));
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d &a = mesh.vertices[f[0]], &b = mesh.vertices[f[1]], &c = mesh.vertices[f[2]];
    const Eigen::Vector3d fl = a.cwiseMin(b).cwiseMin(c), fh = a.cwiseMax(b).cwiseMax(c);
    const int j0 = std::max(0, static_cast<int>(std::floor((fl.y() - lo.y()) / h.y() - 0.5)));
    const int j1 = std::min(dims(1) - 1, static_cast<int>(std::ceil((fh.y() - lo.y()) / h.y() - 0.5)));
    const int k0 = std::max(0, static_cast<int>(std::floor((fl.z() - lo.z()) / h.z() - 0.5)));
    const int k1 = std::min(dims(2) - 1, static_cast<int>(std::ceil((fh.z() - lo.z()) / h.z() - 0.5)));
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const double y = lo.y() + (j + 0.5 + kRayOffsetY) * h.y(), z = lo.z() + (k + 0.5 + kRayOffsetZ) * h.z();
        const double x = crossing(a, b, c, y, z);
        if (!std::isnan(x)) hits[j + static_cast<std::size_t>(dims(1)) * k].push_back(x);
      }
  }
  std::vector<char> active(static_cast<std::size_t>(dims.prod()), 0);
  for (int k = 0; k < dims(2); ++k)
    for (int j = 0; j < dims(1); ++j) {
      auto& column = hits[j + static_cast<std::size_t>(dims(1)) * k];
      std::sort(column.begin(), column.end());
      for (int i = 0; i < dims(0); ++i) {
        const double x = lo.x() + (i + 0.5) * h.x();
        const auto after = column.end() - std::upper_bound(column.begin(), column.end(), x);
        active[i + dims(0) * (j + static_cast<std::size_t>(dims(1)) * k)] = after % 2 == 1;
      }
    }
  return tetsFromCells(lo, h, dims, active, config.order);
}

double medianParticleEdge(const core::ParticleCloud& cloud) {
  std::vector<double> volumes;
  for (double v : cloud.volumes)
    if (v > 0) volumes.push_back(v);
  if (volumes.empty()) return 0.0;
  std::nth_element(volumes.begin(), volumes.begin() + volumes.size() / 2, volumes.end());
  return std::cbrt(volumes[volumes.size() / 2]);
}

TetMesh voxelMeshFromParticles(const core::ParticleCloud& cloud, const VoxelMeshConfig& config) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.volumes[i] > 0) {
      lo = lo.cwiseMin(cloud.positions[i]);
      hi = hi.cwiseMax(cloud.positions[i]);
    }
  const double spacing = medianParticleEdge(cloud);
  if (!(spacing > 0)) throw core::Error("voxel mesh: the particle cloud has no particle with volume > 0");
  const double cell = config.cell > 0.0 ? config.cell : spacing;
  checkCell(cell);
  // Cells coarser than the particles' own start on the particles' cell boundaries (a whole number
  // of particle cells each when cell is a multiple of the spacing) and hold when the particles in
  // them fill at least half of them: "holds a particle" would widen the body by up to a cell.
  const bool coarse = cell > 1.5 * spacing;
  const Eigen::Vector3d lower = lo - Eigen::Vector3d::Constant(0.5 * (coarse ? spacing : cell));
  const Eigen::Vector3i dims = (((hi - lower) / cell).array().floor() + 1.0).cast<int>().matrix();
  if (static_cast<double>(dims.prod()) > 2e7)
    throw core::Error("voxel mesh: cell size " + std::to_string(cell) + " gives too many cells; use a larger one");
  std::vector<double> filled(static_cast<std::size_t>(dims.prod()), 0.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!(cloud.volumes[i] > 0)) continue;
    Eigen::Vector3i c = ((cloud.positions[i] - lower) / cell).array().floor().cast<int>().matrix();
    for (int a = 0; a < 3; ++a) c(a) = std::clamp(c(a), 0, dims(a) - 1);
    filled[c(0) + dims(0) * (c(1) + static_cast<std::size_t>(dims(1)) * c(2))] += cloud.volumes[i];
  }
  std::vector<char> active(filled.size(), 0);
  for (std::size_t k = 0; k < filled.size(); ++k)
    active[k] = coarse ? filled[k] >= 0.5 * cell * cell * cell : filled[k] > 0.0;
  return tetsFromCells(lower, Eigen::Vector3d::Constant(cell), dims, active, config.order);
}

bool particlesFormALattice(const core::ParticleCloud& cloud) {
  const double spacing = medianParticleEdge(cloud);
  if (!(spacing > 0)) return false;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300);
  long with_volume = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.volumes[i] > 0) {
      lo = lo.cwiseMin(cloud.positions[i]);
      ++with_volume;
    }
  const Eigen::Vector3d lower = lo - Eigen::Vector3d::Constant(0.5 * spacing);
  std::set<std::array<long, 3>> cells;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!(cloud.volumes[i] > 0)) continue;
    const Eigen::Vector3d c = ((cloud.positions[i] - lower) / spacing).array().floor();
    cells.insert({static_cast<long>(c(0)), static_cast<long>(c(1)), static_cast<long>(c(2))});
  }
  // A lattice puts one particle in each cell; a Poisson cloud leaves about a third of them empty.
  return static_cast<double>(cells.size()) >= 0.95 * static_cast<double>(with_volume);
}

}  // namespace demnerf::mechanics
