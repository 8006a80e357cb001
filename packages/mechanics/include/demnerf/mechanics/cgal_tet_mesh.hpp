#pragma once
// Unstructured tetrahedral meshes of a closed surface by CGAL's Mesh_3 (Delaunay refinement with
// the surface's sharp edges protected): the FEM baseline's mesh for scanned bodies, which unlike
// the voxel mesh follows slanted and curved faces instead of staircasing them.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

struct CgalMeshConfig {
  /// Target tetrahedron edge length (m), also the bound on surface facets and sharp-edge segments.
  /// 0: 1/20 of the surface's bounding-box diagonal.
  double cell = 0.0;
  /// Largest distance between a surface facet and the input surface (m). 0: cell / 10.
  double facet_distance = 0.0;
  /// Creases whose triangles' normals differ by more than this (degrees) are the body's edges.
  double feature_angle = 60.0;
  /// ... unless more than this fraction of the creases' length is in creases with a dangling end
  /// (one that fades out in a smooth face: a scanned or NeRF-extracted surface's bumps; the NeRF
  /// cuboid and T-bar: 63 % and 79 %, the exact ones 0 %). Then no crease is protected: protecting
  /// them made tetrahedra far below `cell` (NeRF cuboid, cell 16.7 mm: 129,733 instead of 2,950).
  double max_dangling_fraction = 0.25;
  /// false: protect no crease whatever the surface (one reconstructed from particles, whose
  /// creases are the sampling grid's and whose count of dangling ones sits near any threshold:
  /// protected, they stalled Mesh_3 for minutes on a 0.125 m cuboid).
  bool protect_creases = true;
  int order = 2;  ///< 1: TET4, 2: TET10 (straight edge midpoints, elevateToQuadratic)
  /// Seed of CGAL's random generator (initial surface points): the same seed gives nearly the same
  /// mesh; calls may differ by a few tetrahedra (CGAL orders some containers by address, see the .cpp).
  int seed = 1;
  /// Planes the mesh conforms to where they cross the body (more than a tenth of a cell from its
  /// vertices on both sides): facets and nodes on the cross-section, except along its rim, where
  /// elements may straddle the plane (the rim is not protected). A held volume's boundary
  /// (held_volume_planes.hpp: a halfspace fixture's plane, the faces of a box that holds a volume
  /// across the body), so the FEM holds the body up to it rather than up to the last layer of
  /// nodes short of it.
  struct Plane {
    Eigen::Vector3d point, normal;
  };
  std::vector<Plane> cut_planes;
};

/// Whether `surface`'s creases (sharpCurves at feature_angle) are noise by max_dangling_fraction,
/// so that cgalMeshFromSurface protects none of them.
bool creasesAreNoise(const core::TriangleMesh& surface, const CgalMeshConfig& config);

/// Tetrahedra filling the closed, consistently oriented triangle surface `surface`; edges where
/// neighbouring faces meet at more than feature_angle are kept as sharp edges of the mesh (unless
/// creasesAreNoise), so the faces of box-like bodies stay planar. Elements have
/// positive volume; only used nodes are kept.
/// Throws core::Error for an empty or open surface, a bad config value, or an empty result.
TetMesh cgalMeshFromSurface(const core::TriangleMesh& surface, const CgalMeshConfig& config);

}  // namespace demnerf::mechanics
