#pragma once
// Pieces the three samplers share (not part of the public API).

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/lattice_crossings.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/particle_sampler.hpp"

namespace demnerf::geometry::detail {

using Rng = std::mt19937_64;

/// A validated closed mesh turned outward, with per-face data and an inside test.
struct PreparedMesh {
  core::TriangleMesh mesh;
  MeshSummary summary;
  std::vector<Eigen::Vector3d> normals;  ///< unit, outward, per face
  std::vector<double> face_areas;
  std::vector<double> cumulative_area;   ///< running sum of face_areas, for area-weighted picks
  InsideTest inside;

  double volume() const { return summary.volume(); }
  double area() const { return summary.area; }
  const Eigen::AlignedBox3d& bounds() const { return summary.bounds; }
  /// A point uniformly distributed over the surface (by area); `face` receives its face.
  Eigen::Vector3d randomSurfacePoint(Rng& rng, int* face) const;
};

PreparedMesh prepareMesh(const core::TriangleMesh& mesh);

/// Points bucketed in a dense grid of cubic cells, for "anything within r?" and nearest-point
/// queries. Points outside the box land in its border cells, so queries stay correct.
class PointGrid {
 public:
  PointGrid(const Eigen::AlignedBox3d& box, double cell);
  int insert(const Eigen::Vector3d& point);  ///< returns the point's id (0, 1, ...)
  /// True when a stored point is closer than r (r must not exceed the cell size).
  bool anyWithin(const Eigen::Vector3d& point, double r) const;
  /// Id of the nearest stored point, -1 when empty.
  int nearest(const Eigen::Vector3d& point) const;
  /// Id of the nearest stored point whose direction (`directions[id]`) has a positive dot
  /// product with `direction`; the plain nearest point when none has.
  int nearestFacing(const Eigen::Vector3d& point, const Eigen::Vector3d& direction,
                    const std::vector<Eigen::Vector3d>& directions) const;
  /// Calls visit(id) for every stored point closer than r (any r).
  template <typename Visit>
  void forEachWithin(const Eigen::Vector3d& point, double r, Visit&& visit) const {
    const Eigen::Vector3i c = cellOf(point);
    const int rings = static_cast<int>(std::ceil(r / cell_));
    for (int z = std::max(0, c.z() - rings); z <= std::min(dims_.z() - 1, c.z() + rings); ++z)
      for (int y = std::max(0, c.y() - rings); y <= std::min(dims_.y() - 1, c.y() + rings); ++y)
        for (int x = std::max(0, c.x() - rings); x <= std::min(dims_.x() - 1, c.x() + rings); ++x)
          for (int id = head_[cellIndex({x, y, z})]; id >= 0; id = next_[id])
            if ((points_[id] - point).squaredNorm() < r * r) visit(id);
  }
  const Eigen::Vector3d& point(int id) const { return points_[id]; }
  std::size_t size() const { return points_.size(); }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& point) const;
  std::size_t cellIndex(const Eigen::Vector3i& cell) const {
    return (static_cast<std::size_t>(cell.z()) * dims_.y() + cell.y()) * dims_.x() + cell.x();
  }

  Eigen::Vector3d origin_;
  double cell_;
  Eigen::Vector3i dims_;
  std::vector<int> head_;
  std::vector<int> next_;
  std::vector<Eigen::Vector3d> points_;
};

/// What a sampler places, before volumes, normals and colours are attached.
struct SampleSet {
  std::vector<Eigen::Vector3d> interior;
  std::vector<Eigen::Vector3d> surface;
  std::vector<int> surface_faces;
  std::vector<double> surface_areas;  ///< area weights (any positive scale; normalised later)
};

/// The fine lattice that measures Voronoi volumes and the grid sampler's nodes share a layout.
Lattice layoutLattice(const GridLayout& layout);
/// A lattice `resolution` times finer whose nodes split each cell of `layout` evenly.
Lattice refinedLattice(const GridLayout& layout, int resolution);

/// Volume of each particle's Voronoi cell within the body, on a fine lattice, scaled so the sum
/// is the mesh volume. Every particle gets at least half a fine cell.
std::vector<double> voronoiVolumes(const PreparedMesh& prepared, const std::vector<Eigen::Vector3d>& particles,
                                   double spacing, int resolution);

/// Area weights of surface points by nearest-point assignment of a dense uniform pool of
/// surface points (a discrete Voronoi diagram on the surface), summing to the mesh area. A pool
/// point only goes to a surface point whose face normal agrees with its own, so the two sides
/// of a thin part (a finger, an ear) do not steal each other's area.
std::vector<double> voronoiAreas(const PreparedMesh& prepared, const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<int>& faces, double spacing, Rng& rng);

/// What each surface point of a SampleSet carries besides its position (surface_frames.cpp).
struct SurfaceFrames {
  /// Unit, outward: the mean of the surface's triangles within half a spacing that lie within
  /// 60 deg of it, so a bumpy extraction's noise averages out and true edges stay sharp.
  std::vector<Eigen::Vector3d> normals;
  /// Most of the half-ball of one spacing in front of the point is solid (a crack, pocket or thin
  /// cavity of a NeRF extraction): the cloud cannot resolve the gap; not kept as surface.
  std::vector<char> crack_wall;
};
SurfaceFrames surfaceFrames(const PreparedMesh& prepared, const SampleSet& set, double spacing);

// Surface placements.
void sampleSurfaceRandom(const PreparedMesh& prepared, std::size_t count, Rng& rng, SampleSet* set);
void sampleSurfacePoisson(const PreparedMesh& prepared, double radius, Rng& rng, SampleSet* set);
void sampleSurfaceGrid(const PreparedMesh& prepared, const GridLayout& layout, SampleSet* set);

// The three interior samplers (each also places surface points when config.surface is set).
SampleSet sampleRandom(const PreparedMesh& prepared, const SamplerConfig& config, Rng& rng);
SampleSet samplePoisson(const PreparedMesh& prepared, const SamplerConfig& config, Rng& rng);
SampleSet sampleGrid(const PreparedMesh& prepared, const SamplerConfig& config, Rng& rng);

}  // namespace demnerf::geometry::detail
