#pragma once
// Tetrahedral meshes of arbitrary bodies by voxelisation: hexes of a closed surface mesh or of a
// particle cloud, each split into 6 tetrahedra (the FEM baseline's mesh for scanned bodies).

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

struct VoxelMeshConfig {
  /// Hex edge length (m); each axis adjusts it so a whole number of cells spans the bounding box
  /// (box-like bodies then keep their faces exactly). 0: from the particle volumes.
  double cell = 0.0;
  int order = 2;  ///< 1: TET4, 2: TET10
};

/// Hexes whose centre lies inside the closed surface `mesh` (ray parity along x), split into
/// tetrahedra. Throws core::Error when the mesh is empty or no cell lies inside.
TetMesh voxelMeshFromSurface(const core::TriangleMesh& mesh, const VoxelMeshConfig& config);

/// Hexes of a grid aligned with the particles (origin half a cell below the lowest particle with
/// volume) that contain a particle with volume > 0. With config.cell = 0 the cell is the cube
/// root of the median particle volume, which reproduces the cells of a grid-sampled cloud.
TetMesh voxelMeshFromParticles(const core::ParticleCloud& cloud, const VoxelMeshConfig& config);

/// Whether `point` lies inside the closed surface (parity of crossings of a ray along +x).
bool insideSurface(const core::TriangleMesh& mesh, const Eigen::Vector3d& point);

}  // namespace demnerf::mechanics
