#pragma once
// Fewer triangles for the same body: edge collapse (CGAL, Lindstrom-Turk placement, which
// keeps the enclosed volume) down to a face budget.

#include <cstddef>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

struct MeshSimplificationConfig {
  std::size_t max_faces = 100000;  ///< stop once at most this many faces remain; 0: no limit
  /// true: shortest edge first, collapsed to its midpoint (several times faster, may shift
  /// curved parts by a fraction of an edge); false: Lindstrom-Turk cost and placement.
  bool fast = false;
};

struct MeshSimplificationReport {
  std::size_t faces_before = 0;
  std::size_t faces_after = 0;
  std::size_t edges_collapsed = 0;
};

/// Collapses the cheapest edges until at most config.max_faces faces remain (a closed
/// manifold stays closed and manifold: CGAL refuses collapses that would break it). A mesh
/// already within the budget is returned as it is. Throws core::Error for a mesh CGAL cannot
/// take as a manifold surface, naming the face.
core::TriangleMesh simplifyMesh(const core::TriangleMesh& mesh, const MeshSimplificationConfig& config = {},
                                MeshSimplificationReport* report = nullptr);

}  // namespace demnerf::geometry
