#pragma once
// A volume quadrature for the DEM's feature grid that does not depend on how the particles were
// sampled: Gauss points in every grid cell, kept where the body is (ParticleInsideTest), with cells
// the surface cuts subdivided so that their inside part is integrated finely.
//
// Why not the particles themselves (the paper's midpoint rule)? Their weights and spacing are the
// sampler's: a random cloud leaves holes, a grid cloud leaves a layer up to one spacing thick
// between its outermost interior particles and the surface. A grid function whose support lies
// mostly in such a gap is seen by a surface particle's traction but by almost no volume weight,
// so the energy can be lowered without bound there (T-bar twist on `demnerf sample` particles:
// +7 J "converged", 11 % off). Gauss points in the cells see the whole body alike.

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"

namespace demnerf::mechanics {

struct CellQuadratureConfig {
  int points_per_axis = 2;  ///< Gauss-Legendre points per axis and (sub)cell (1-3)
  /// Cells the surface cuts are split in 2 x 2 x 2 this many times; sub-cells wholly inside keep
  /// their Gauss points, the cut ones of the last level keep theirs with weights fitted to their
  /// inside part (moment fitting on a 6^3 lattice of probes).
  int boundary_levels = 2;
  /// Fixture regions whose whole volume is held (no held face, held_face.hpp): D = 0 inside them,
  /// so Gauss points there see nothing of the field. Cells their boundary cuts are split like
  /// surface-cut ones, and at the last level the free and the held part are moment-fitted apart,
  /// so the free part of every cell carries points (a cell whose points all fell in the held part
  /// left the free strip beside it unintegrated, and the field inverted there).
  std::vector<core::Region> held_volumes;
  /// Threads that run the cells (0: every core); the points come out in the same order on any count.
  int threads = 0;
  /// Called on the calling thread with the share of the cells done (about every 1 %); it may throw
  /// (a time limit, a cancel): the other threads then stop at their next cell and it is rethrown.
  std::function<void(double done)> progress;
};

struct CellQuadrature {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> weights;  ///< m^3; they sum to the particles' total volume
  double raw_volume = 0.0;      ///< the sum before it was scaled to the particles' volume (m^3)
};

/// Gauss points over the grid's cells inside the body the cloud describes. Throws core::Error when
/// no point lies inside (a cloud without volume, or one the grid does not cover).
CellQuadrature cellQuadrature(const core::ParticleCloud& cloud, const BsplineGrid& grid,
                              const CellQuadratureConfig& config = {});

}  // namespace demnerf::mechanics
