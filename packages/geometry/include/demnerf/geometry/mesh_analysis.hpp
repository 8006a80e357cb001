#pragma once
// Measures of a triangle mesh (volume, area, bounds, closedness) and the checks samplers need.

#include <Eigen/Geometry>
#include <string>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

/// What a mesh is: its size, extent and whether it bounds a volume.
struct MeshSummary {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  double signed_volume = 0.0;  ///< divergence theorem; > 0 when faces point outward
  double area = 0.0;
  Eigen::AlignedBox3d bounds;
  std::size_t boundary_edges = 0;      ///< edges used by one face only (holes)
  std::size_t non_manifold_edges = 0;  ///< edges used by more than two faces
  std::size_t misoriented_edges = 0;   ///< edges whose two faces traverse it the same way
  std::size_t degenerate_faces = 0;    ///< repeated vertex or zero area

  /// Every edge has exactly two faces that traverse it in opposite directions.
  bool closed() const {
    return faces > 0 && boundary_edges == 0 && non_manifold_edges == 0 && misoriented_edges == 0;
  }
  double volume() const { return signed_volume < 0 ? -signed_volume : signed_volume; }
  double diagonal() const { return bounds.isEmpty() ? 0.0 : bounds.diagonal().norm(); }
};

/// Measures the mesh. Throws core::Error when a face indexes a missing vertex or a vertex is
/// NaN/Inf (nothing else can be measured then).
MeshSummary analyzeMesh(const core::TriangleMesh& mesh);

/// Throws core::Error with an actionable message unless the mesh is a closed, consistently
/// oriented, non-degenerate triangle mesh enclosing a positive volume. `what` names the mesh
/// in the message (a file name). Returns the summary.
MeshSummary requireClosedMesh(const core::TriangleMesh& mesh, const std::string& what = "mesh");

/// The same mesh with every face reversed (turns an inward-facing mesh outward).
core::TriangleMesh flippedFaces(const core::TriangleMesh& mesh);

}  // namespace demnerf::geometry
