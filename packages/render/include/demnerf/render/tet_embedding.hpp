#pragma once
// A tetrahedral embedding of a particle body: Delaunay tetrahedra of the rest positions kept
// where they lie inside the body, moved by the nodal displacements, with a point locator that
// maps a deformed point back to its rest position (barycentric, i.e. piecewise-linear).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::render {

struct TetEmbeddingConfig {
  /// Tetrahedra whose longest edge exceeds this many typical particle spacings (median
  /// nearest-neighbour distance) are dropped: they bridge concavities or span the hull's
  /// outside, not the body.
  double max_edge_factor = 2.5;
  /// Points outside every tetrahedron but within this many spacings of one (by its face planes)
  /// are mapped by the nearest tetrahedron's affine map extended: the NeRF's surface is a few
  /// voxels thick and extends past the outermost particles.
  double margin_factor = 0.75;
  /// Tetrahedra flatter than this (volume / longest edge^3) carry no volume of their own
  /// (Delaunay slivers of cospherical grid points) and are dropped.
  double min_shape = 1e-3;
  /// Locator grid cell edge in spacings.
  double cell_factor = 1.0;
};

/// Where a deformed point came from.
struct RestPoint {
  float rest[3];   ///< rest position X
  int tet = -1;    ///< -1: outside the body (and its margin)
};

class TetEmbedding {
 public:
  /// Throws core::Error when the result is unusable: fewer than 4 particles, a non-finite
  /// position or displacement, all particles coplanar, or no tetrahedron left after filtering.
  TetEmbedding(const core::ResultField& result, const TetEmbeddingConfig& config = {});

  std::size_t tetCount() const { return tets_.size(); }
  std::size_t particleCount() const { return rest_.size(); }
  double spacing() const { return spacing_; }
  double margin() const { return margin_; }
  /// Deformed box of the body grown by the margin.
  const Eigen::Vector3d& deformedMin() const { return box_min_; }
  const Eigen::Vector3d& deformedMax() const { return box_max_; }
  /// Corners (rest / deformed) of tetrahedron t.
  const std::array<int, 4>& tet(std::size_t t) const { return tets_[t]; }
  const std::vector<Eigen::Vector3d>& restPositions() const { return rest_; }
  const std::vector<Eigen::Vector3d>& deformedPositions() const { return deformed_; }
  /// Smallest deformed-to-rest volume ratio J over the kept tetrahedra (<= 0: inverted).
  double minVolumeRatio() const { return min_volume_ratio_; }

  /// The rest point of deformed point x: inside a tetrahedron, or within the margin of one.
  RestPoint locate(const float* x) const;
  /// Rotates a deformed-space direction to rest space by the tetrahedron's local rotation
  /// (R^T d with F = R U the polar decomposition of its deformation gradient).
  void restDirection(int tet, const float* direction, float* rest_direction) const;

 private:
  struct Map {
    float x0[3];          ///< deformed corner 0
    float inv[9];         ///< deformed edge matrix inverse (row-major): b = inv (x - x0)
    float plane_scale[4]; ///< 1 / |grad b_i|: b_i * scale = signed distance to face i
    float rest0[3];       ///< rest corner 0
    float affine[9];      ///< X = rest0 + affine (x - x0) (row-major)
    float rotation[9];    ///< R (row-major), polar rotation of F
  };

  /// Keeps Delaunay cell v (rest corners) unless it is too long, a sliver or inverted by the
  /// displacement; updates min_volume_ratio_.
  void addTetrahedron(const std::array<int, 4>& v, const TetEmbeddingConfig& config, double max_edge);
  /// The locator grid over the kept tetrahedra's deformed boxes grown by the margin.
  void buildLocator(double cell_factor);

  std::vector<Eigen::Vector3d> rest_, deformed_;
  std::vector<std::array<int, 4>> tets_;
  std::vector<Map> maps_;
  double spacing_ = 0, margin_ = 0, min_volume_ratio_ = 1;
  Eigen::Vector3d box_min_, box_max_;
  // Uniform locator grid over the deformed box: cell -> tets whose grown box overlaps it (CSR).
  int dims_[3] = {1, 1, 1};
  double cell_ = 1;
  std::vector<std::int32_t> cell_start_, cell_tets_;
};

}  // namespace demnerf::render
