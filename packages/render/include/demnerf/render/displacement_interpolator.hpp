#pragma once
// A displacement field known at particles, evaluated anywhere on the body by a moving
// least-squares linear fit over the nearest particles.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::render {

struct InterpolatorConfig {
  int neighbours = 16;  ///< particles in each local fit
  /// A query point is "covered" when its nearest particle is at most this many typical particle
  /// spacings away (the spacing is the median nearest-neighbour distance among the particles).
  double coverage_factor = 6.0;
  /// Directions in which the neighbours spread less than this share of the largest spread
  /// (covariance eigenvalue) get no fitted gradient: keeps the fit stable where the particles
  /// are nearly coplanar (a one-layer membrane).
  double gradient_cutoff = 1e-4;
};

/// Moving least squares, linear basis: at a query x the field is a + B (X - c) fitted to the k
/// nearest particles with weights w = (1 - (d/h)^2)^2 (h just beyond the k-th neighbour, c the
/// weighted centroid). A linear field is reproduced exactly; smooth fields with error O(spacing^2).
class DisplacementInterpolator {
 public:
  /// Throws core::Error when there are fewer particles than a fit needs or values are not finite.
  DisplacementInterpolator(const std::vector<Eigen::Vector3d>& positions,
                           const std::vector<Eigen::Vector3d>& displacements,
                           const InterpolatorConfig& config = {});
  ~DisplacementInterpolator();

  Eigen::Vector3d at(const Eigen::Vector3d& point) const;
  std::vector<Eigen::Vector3d> at(const std::vector<Eigen::Vector3d>& points) const;

  double typicalSpacing() const { return spacing_; }
  double distanceToNearest(const Eigen::Vector3d& point) const;

  /// Throws core::Error naming the worst point when some point is farther than
  /// coverage_factor x spacing from every particle: the field does not cover that body.
  /// Returns the largest nearest-particle distance.
  double checkCovers(const std::vector<Eigen::Vector3d>& points, const std::string& what) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  InterpolatorConfig config_;
  double spacing_ = 0.0;
};

/// The mesh with every vertex moved by the field.
core::TriangleMesh deformMesh(const core::TriangleMesh& rest, const DisplacementInterpolator& field);

}  // namespace demnerf::render
