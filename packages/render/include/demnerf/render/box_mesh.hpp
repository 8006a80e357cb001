#pragma once
// Closed, outward-oriented triangle meshes of solids made of hexahedral cells on a structured grid.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::render {

/// A solid described by a structured grid of cells: cell (i, j, k) is part of the body when
/// `occupied` says so; grid node (i, j, k), 0 <= i <= cells[0], sits at `node(i, j, k)`. The map
/// must preserve orientation (positive Jacobian) so that faces stay outward.
struct StructuredSolid {
  std::array<int, 3> cells{1, 1, 1};
  std::function<bool(int, int, int)> occupied;
  std::function<Eigen::Vector3d(int, int, int)> node;
};

/// The boundary of the solid: every cell face between a body cell and a non-body cell becomes
/// two triangles, counter-clockwise seen from outside. Nodes are shared, so the mesh is closed
/// (watertight) as long as no two body cells touch only along an edge or a corner.
core::TriangleMesh meshStructuredSolid(const StructuredSolid& solid);

/// A union of axis-aligned boxes meshed on the rectilinear grid made of all box faces, each
/// interval subdivided so that no grid edge is longer than `max_edge` (metres).
core::TriangleMesh meshBoxUnion(const std::vector<Eigen::AlignedBox3d>& boxes, double max_edge);

/// Volume enclosed by a closed, outward-oriented mesh (divergence theorem); negative when the
/// faces point inward. Used to check orientation.
double enclosedVolume(const core::TriangleMesh& mesh);

/// Number of edges not shared by exactly two faces with opposite directions (0 for a closed,
/// consistently oriented mesh).
std::size_t countBoundaryOrInconsistentEdges(const core::TriangleMesh& mesh);

}  // namespace demnerf::render
