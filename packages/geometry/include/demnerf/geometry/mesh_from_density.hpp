#pragma once
// Density grid -> closed surface mesh: iso-surface, largest component, holes, orientation.

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_grid.hpp"
#include "demnerf/geometry/mesh_repair.hpp"

namespace demnerf::geometry {

struct MeshExtractionConfig {
  /// Density at the surface. 2.5 is instant-ngp's default for its marching cubes; see
  /// densityForOpacity() for a threshold chosen by opacity.
  double threshold = 2.5;
  MeshRepairConfig repair;
};

struct MeshExtractionResult {
  core::TriangleMesh mesh;
  std::size_t vertices = 0;
  std::size_t faces = 0;
  double volume = 0.0;
  double area = 0.0;
  bool closed = false;
  MeshRepairReport repair;
};

/// Extracts and repairs the surface. Throws core::Error naming the threshold and the grid's
/// density range when no cell crosses the threshold.
MeshExtractionResult extractMesh(const DensityGrid& grid, const MeshExtractionConfig& config = {});

}  // namespace demnerf::geometry
