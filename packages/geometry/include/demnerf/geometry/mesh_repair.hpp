#pragma once
// Turns a raw surface (from marching cubes or a scan) into a closed, outward-oriented body.

#include <cstddef>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

struct MeshRepairConfig {
  bool keep_largest_component = true;  ///< drops floaters (NeRF density noise)
  bool fill_holes = true;              ///< triangulates and refines every boundary loop
  bool orient_outward = true;          ///< reverses all faces when they enclose negative volume
  int smoothing_iterations = 0;        ///< Taubin (lambda/mu) passes; 0 keeps the mesh as is
};

struct MeshRepairReport {
  std::size_t components_removed = 0;
  std::size_t holes_filled = 0;
  std::size_t duplicate_vertices_merged = 0;
  bool flipped = false;
};

/// Merges duplicate vertices, drops degenerate faces, makes orientation consistent, then
/// applies the steps the config enables (CGAL Polygon Mesh Processing). Throws core::Error
/// when the mesh is empty or nothing is left.
core::TriangleMesh repairMesh(const core::TriangleMesh& mesh, const MeshRepairConfig& config = {},
                              MeshRepairReport* report = nullptr);

struct SmoothingConfig {
  int iterations = 5;
  double lambda = 0.5;  ///< shrinking step
  double mu = -0.53;    ///< inflating step (|mu| > lambda keeps the volume)
};

/// Taubin smoothing: removes the staircase of a voxel surface without shrinking the body.
core::TriangleMesh smoothMesh(const core::TriangleMesh& mesh, const SmoothingConfig& config = {});

}  // namespace demnerf::geometry
