#pragma once
// Unstructured tetrahedral meshes of a closed surface by CGAL's Mesh_3 (Delaunay refinement with
// the surface's sharp edges protected): the FEM baseline's mesh for scanned bodies, which unlike
// the voxel mesh follows slanted and curved faces instead of staircasing them.

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

struct CgalMeshConfig {
  /// Target tetrahedron edge length (m), also the bound on surface facets and sharp-edge segments.
  /// 0: 1/20 of the surface's bounding-box diagonal.
  double cell = 0.0;
  /// Largest distance between a surface facet and the input surface (m). 0: cell / 10.
  double facet_distance = 0.0;
  int order = 2;  ///< 1: TET4, 2: TET10 (straight edge midpoints, elevateToQuadratic)
  /// Seed of CGAL's random generator (initial surface points): the same seed gives nearly the same
  /// mesh; calls may differ by a few tetrahedra (CGAL orders some containers by address, see the .cpp).
  int seed = 1;
};

/// Tetrahedra filling the closed, consistently oriented triangle surface `surface`; edges where
/// neighbouring faces meet at more than 60 degrees are kept as sharp edges of the mesh, so the faces
/// of box-like bodies stay planar. Elements have positive volume; only used nodes are kept.
/// Throws core::Error for an empty or open surface, a bad config value, or an empty result.
TetMesh cgalMeshFromSurface(const core::TriangleMesh& surface, const CgalMeshConfig& config);

}  // namespace demnerf::mechanics
