#pragma once
// The FEM's automatic mesh size: a cell chosen from the body (its thickness, volume) and the
// accuracy asked for, not from how densely it was sampled, so the same body gets the same mesh
// whether it comes with 2k or 200k particles.

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

/// What the mesh-size rule needs to know about a body.
struct BodyMeasures {
  double volume = 0.0;  ///< m^3
  double area = 0.0;    ///< surface area (m^2); 0 when unknown
  Eigen::Vector3d lower = Eigen::Vector3d::Zero(), upper = Eigen::Vector3d::Zero();  ///< bounding box
  /// The body's thickness: the smaller of the bounding box's shortest side and 4 V / A (the side
  /// of a square bar, twice the thickness of a plate, 2/3 of a cube's side; the bounding box
  /// catches axis-aligned plates). Without an area, the bounding box's shortest side.
  double thickness() const;
};

/// Volume (divergence theorem), area and bounding box of a closed, outward-oriented surface.
/// Throws core::Error for an empty surface or one that encloses no volume.
BodyMeasures measureSurface(const core::TriangleMesh& surface);

/// Volume (sum of particle volumes), area (sum of surface shares) and bounding box of a cloud.
/// Throws core::Error when no particle has a volume.
BodyMeasures measureParticles(const core::ParticleCloud& cloud);

/// The rule, as VoxelMeshConfig carries it (see there for the defaults and their measured effect).
struct MeshSizeRule {
  double elements_across = 6.0;  ///< target elements across the body's thickness (accuracy)
  double max_dofs = 60000.0;     ///< cap on the expected degrees of freedom (cost)
  int order = 2;                 ///< 1: TET4, 2: TET10 (sets the dofs per element)
};

/// Expected degrees of freedom of a tetrahedral mesh of cell h: 6 V / h^3 tetrahedra (six per cube
/// of edge h), times 3 x nodes per tetrahedron (TET10 1.5: Kuhn voxels 1.33, CGAL Mesh_3 ~1.7 with
/// ~0.8 of the tetrahedra; TET4 0.2).
double expectedDofs(double volume, double cell, int order);

/// Cell (target tetrahedron edge or hex edge, m): thickness / elements_across, raised where needed
/// so that expectedDofs() stays <= max_dofs. Throws core::Error for a rule value that is not a
/// positive number.
double automaticCell(const BodyMeasures& body, const MeshSizeRule& rule);

}  // namespace demnerf::mechanics
