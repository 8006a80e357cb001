#pragma once
// Is a point inside the body a particle cloud describes? Within two particle spacings of surface
// particles (area > 0, outward unit normal): when it lies behind the nearest one's tangent plane
// (on a rough face, the same-face neighbours' planes blended; with the planes of other faces' particles
// across an edge), and beyond 1.5 spacings of them only with a volume-carrying
// particle within 1.5 spacings; farther from them, when the nearest particle carries volume and
// lies within 1.5 spacings. The cloud alone is enough, whichever sampler
// (random, Poisson disk, grid, a NeRF extraction) made it, so quadratures built on this test do not
// depend on how the particles were placed.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

class ParticleInsideTest {
 public:
  /// Keeps a copy of positions, normals and the surface flags. A point farther than
  /// `reach` x the mean particle spacing from every particle is outside.
  explicit ParticleInsideTest(const core::ParticleCloud& cloud, double reach = 3.0);

  bool inside(const Eigen::Vector3d& x) const;
  /// Signed distance to the surface the particles describe (m; negative inside), from the tangent
  /// planes of the nearest surface particles: exact for a planar face, and how the cell quadrature
  /// measures the inside part of a small cube to better than the cube's size. Beyond the surface
  /// particles' reach only the side is known: -/+ (kSurfaceRadius + 1) spacings.
  double signedDistance(const Eigen::Vector3d& x) const { return signedDistance(x, nullptr); }
  /// The same, and the unit normal of the tangent plane that gave it (`normal`, may be null), so
  /// that x - d n is the nearest point of the surface; zero beyond the surface particles' reach.
  double signedDistance(const Eigen::Vector3d& x, Eigen::Vector3d* normal) const;
  /// The surface particles that can decide signedDistance() at any point of the box [lo, hi], in
  /// the order it visits them, with their buckets. Gathered once for the many probes of a small
  /// cube (the cell quadrature's cut cells: 216 probes each, most of a T-bar solve's set-up), which
  /// then skip the bucket search.
  struct SurfaceNeighbours {
    Eigen::Vector3i lo, hi;  ///< the box's buckets
    std::vector<int> index;
    std::vector<Eigen::Vector3i> bucket;
  };
  void surfaceNeighbours(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, SurfaceNeighbours& out) const;
  /// signedDistance(x) for x in the box `near` was gathered for: the same value, bit for bit.
  double signedDistance(const Eigen::Vector3d& x, const SurfaceNeighbours& near) const;
  /// The cube root of the body's volume per volume-carrying particle (m).
  double spacing() const { return spacing_; }
  /// Sum of the particles' volumes (m^3).
  double volume() const { return volume_; }
  /// Sum of the surface particles' areas (m^2).
  double surfaceArea() const { return surface_area_; }
  /// Moves the surface out by this distance (m; negative: in). Lattice clouds whose surface
  /// particles carry a whole cell of volume describe a body half a cell larger than the particles'
  /// hull; cellQuadrature() sets the offset that makes the enclosed volume the particles' volume.
  void setSurfaceOffset(double offset) { offset_ = offset; }
  /// Surface particles whose face is not flat around them (same-face neighbours off their plane):
  /// their distances blend the face's planes. None on an exact (flat-faced) body.
  std::size_t roughParticles() const;
  /// roughParticles() over the surface particles (0 without any): nearly 1 on a NeRF extraction or
  /// a scan, 0 on a sampled flat-faced body.
  double roughShare() const;
  /// Surface particles of another face (normals more than 60 degrees apart) join the nearest one's
  /// plane when they are at most this many spacings farther from the point (default 1). Two
  /// spacings bridge a random cloud's gaps at its edges (surfaceLoads() uses them); on a NeRF
  /// extraction's bumpy surface they join bumps as edges (the T-bar's NeRF clouds 0.4-0.5 % worse
  /// in rel. L2), so the volume quadrature keeps one.
  void setEdgeReach(double spacings) { edge_reach_ = spacings; }
  /// Whether a rough face's distance blends its planes (default true: the DEM's quadrature and
  /// loads). The FEM's surface of the particles (particleSurface) keeps the nearest plane: with the
  /// blend its NeRF T-bar meshes came out 0.3-1.1 % stiffer against TET10 on the extracted surface,
  /// where the nearest plane's were within 0.2-0.7 % (docs/dem_feature_grid.md, "Rough faces").
  void setBlendRoughFaces(bool blend) { blend_rough_ = blend; }
  /// Surface particles whose normals differ by more than this angle (cos 60 deg) lie on different
  /// faces: an edge between them (distanceNear(); surfaceLoads() tells edges the same way).
  static constexpr double kEdgeCosine = 0.5;

 private:
  static constexpr double kSurfaceRadius = 2.0;  ///< in particle spacings
  /// Beyond kSurfaceRadius of every surface particle, a point is inside when a volume-carrying
  /// particle is within this many spacings (clouds with surface particles; signedDistance()).
  static constexpr double kDeepReach = 1.5;
  Eigen::Vector3i bucket(const Eigen::Vector3d& x) const;
  long bucketIndex(const Eigen::Vector3i& c) const;  ///< -1 outside the table
  template <typename Visit>
  void forEachIn(const Eigen::Vector3i& c, Visit&& visit) const;
  /// Visits the surface particles of the buckets within kNearRings of c, in bucket order.
  template <typename Visit>
  void forEachSurfaceNear(const Eigen::Vector3i& c, Visit&& visit) const;
  /// The signed distance from the surface particles `nearby` visits; false when none is near.
  template <typename Nearby>
  bool nearSurface(const Eigen::Vector3d& x, Nearby&& nearby, Eigen::Vector3d* normal, double& d) const;
  template <typename Nearby>
  double distanceNear(const Eigen::Vector3d& x, int nearest, Nearby&& nearby, int& active) const;
  /// Distance to the nearest volume-carrying particle within kDeepReach spacings of x (bucket c);
  /// infinity when there is none.
  double nearestCarrier(const Eigen::Vector3d& x, const Eigen::Vector3i& c) const;
  /// Beyond the surface particles' reach: inside or outside from the nearest particle (bucket c).
  double deepSide(const Eigen::Vector3d& x, const Eigen::Vector3i& c) const;
  static constexpr int kNearRings = 2;  ///< ceil(kSurfaceRadius): buckets searched for surface particles
  /// A rough face's distance blends the planes of same-face particles (normals within 30 degrees:
  /// kSameFace, as surfaceRoughness() selects them) within this many spacings: at least
  /// kSurfaceRadius, so the nearest particle always weighs in, and at most kNearRings (the buckets).
  static constexpr double kBlendRadius = 2.0;
  static constexpr double kSameFace = 0.866;
  /// Flags the surface particles whose same-face neighbours do not all lie on their plane.
  void markRough();
  template <typename Nearby>
  double blendedDistance(const Eigen::Vector3d& x, int nearest, Nearby&& nearby) const;

  std::vector<Eigen::Vector3d> positions_, normals_;
  std::vector<char> surface_;
  std::vector<char> carries_;  ///< the particle carries volume
  std::vector<char> rough_;    ///< a surface particle whose face is not flat around it (markRough())
  double surface_area_ = 0.0, offset_ = 0.0, edge_reach_ = 1.0;
  bool blend_rough_ = true;
  double spacing_ = 0.0, volume_ = 0.0, bucket_ = 1.0, reach_ = 0.0;
  Eigen::Vector3d lower_;
  Eigen::Vector3i dims_;
  std::vector<long> start_;  ///< bucket b holds members_[start_[b] .. start_[b + 1])
  std::vector<int> members_;
  /// The surface particles alone, in the same buckets and order (a CSR table as start_, members_):
  /// most probes only look for them, and most particles are not.
  std::vector<long> surface_start_;
  std::vector<int> surface_members_;
};

}  // namespace demnerf::mechanics
