#include <algorithm>
#include <cmath>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

Lattice layoutLattice(const GridLayout& layout) {
  Lattice lattice;
  lattice.origin = layout.origin;
  lattice.spacing = Eigen::Vector3d::Constant(layout.spacing);
  lattice.dims = layout.dims;
  return lattice;
}

Lattice refinedLattice(const GridLayout& layout, int resolution) {
  // Cell (i, j, k) of the layout spans node +- spacing / 2; split it into resolution^3 sub-cells
  // and put a fine node at each sub-cell's centre.
  const double fine = layout.spacing / resolution;
  Lattice lattice;
  lattice.origin = layout.origin - Eigen::Vector3d::Constant(0.5 * layout.spacing - 0.5 * fine);
  lattice.spacing = Eigen::Vector3d::Constant(fine);
  lattice.dims = layout.dims * resolution;
  return lattice;
}

std::vector<double> voronoiVolumes(const PreparedMesh& prepared, const std::vector<Eigen::Vector3d>& particles,
                                   double spacing, int resolution) {
  std::vector<double> volumes(particles.size(), 0.0);
  if (particles.empty()) return volumes;
  resolution = std::max(1, resolution);
  const GridLayout layout = gridLayout(prepared.bounds().min(), prepared.bounds().max(), spacing);
  // A long thin body in a large box could ask for a huge lattice: coarsen to ~100M nodes.
  while (resolution > 1 && layout.dims.cast<double>().prod() * std::pow(resolution, 3) > 1e8) --resolution;
  const Lattice fine = refinedLattice(layout, resolution);
  const std::vector<std::uint8_t> inside = classifyLattice(prepared.mesh, fine);

  PointGrid grid(prepared.bounds(), spacing);
  for (const auto& p : particles) grid.insert(p);
  std::vector<double> counts(particles.size(), 0.0);
  for (int k = 0; k < fine.dims.z(); ++k) {
    for (int j = 0; j < fine.dims.y(); ++j) {
      for (int i = 0; i < fine.dims.x(); ++i) {
        if (!inside[fine.index(i, j, k)]) continue;
        counts[grid.nearest(fine.node(i, j, k))] += 1.0;
      }
    }
  }
  // A particle with no fine node nearest to it (random clusters) still stands for some
  // material; half a fine cell keeps its weight positive without biasing the others.
  double total = 0.0;
  for (double& c : counts) {
    c = std::max(c, 0.5);
    total += c;
  }
  const double scale = prepared.volume() / total;
  for (std::size_t i = 0; i < counts.size(); ++i) volumes[i] = counts[i] * scale;
  return volumes;
}

std::vector<double> voronoiAreas(const PreparedMesh& prepared, const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<int>& faces, double spacing, Rng& rng) {
  std::vector<double> areas(points.size(), 0.0);
  if (points.empty()) return areas;
  // About 16 pool points per surface point measure each cell's area to a few percent.
  const std::size_t pool = std::max<std::size_t>(16 * points.size(), 1000);
  PointGrid grid(prepared.bounds(), spacing);
  std::vector<Eigen::Vector3d> normals;
  normals.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    grid.insert(points[i]);
    normals.push_back(prepared.normals[faces[i]]);
  }
  std::vector<double> counts(points.size(), 0.0);
  for (std::size_t s = 0; s < pool; ++s) {
    int face = 0;
    const Eigen::Vector3d p = prepared.randomSurfacePoint(rng, &face);
    counts[grid.nearestFacing(p, prepared.normals[face], normals)] += 1.0;
  }
  double total = 0.0;
  for (double& c : counts) {
    c = std::max(c, 0.5);
    total += c;
  }
  for (std::size_t i = 0; i < counts.size(); ++i) areas[i] = counts[i] / total * prepared.area();
  return areas;
}

}  // namespace demnerf::geometry::detail
