#pragma once
// Sharp creases of a closed triangle surface, chained into curves: what CGAL's Mesh_3 protects as
// the body's edges. A CAD-like surface (a box, the T-bar) has a few long creases; a surface
// extracted from a NeRF has thousands of short ones (bumps of marching cubes and edge collapse),
// and protecting those forces tetrahedra far smaller than the asked mesh size.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

struct SharpCurve {
  std::vector<Eigen::Vector3d> points;  ///< vertex positions along the crease; closed: last == first
  double length = 0.0;
  bool closed = false;
  /// An end lies where no other crease goes on (one sharp edge at that vertex): a crease that fades
  /// out in a smooth surface, which a body's edge does not (those meet at corners or close).
  bool dangling = false;
};

/// Edges whose two triangles' normals differ by more than `angle_degrees`, chained into curves
/// that end where a vertex has other than two sharp edges (corners, branches) or close on
/// themselves. The surface must be a closed two-manifold (every edge in exactly two triangles);
/// edges in other than two triangles are ignored.
std::vector<SharpCurve> sharpCurves(const core::TriangleMesh& surface, double angle_degrees);

}  // namespace demnerf::mechanics
