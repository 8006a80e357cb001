#pragma once
// A plane through a closed body, as an open triangle surface over it: what the CGAL mesher
// conforms to so that a held volume's boundary (a halfspace clamp's plane) carries nodes
// (CgalMeshConfig::cut_planes).

#include <Eigen/Core>

#include "demnerf/core/particle_cloud.hpp"

namespace demnerf::mechanics {

/// Whether the plane through `point` with normal `normal` passes through the body bounded by
/// `surface` with its vertices farther than `clearance` on both sides: a plane on one of its faces
/// (a halfspace that grips the base) or beside it cuts nothing.
bool planeCutsBody(const core::TriangleMesh& surface, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                   double clearance);

/// A square of that plane over the body's vertices and `margin` beyond, as two triangles.
core::TriangleMesh planeSquare(const core::TriangleMesh& surface, const Eigen::Vector3d& point,
                               const Eigen::Vector3d& normal, double margin);

}  // namespace demnerf::mechanics
