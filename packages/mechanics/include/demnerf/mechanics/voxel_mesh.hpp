#pragma once
// Tetrahedral meshes of arbitrary bodies by voxelisation: hexes of a closed surface mesh or of a
// particle cloud, each split into 6 tetrahedra (the FEM baseline's mesh for scanned bodies).

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

struct VoxelMeshConfig {
  /// Hex edge length (m); each axis adjusts it so a whole number of cells spans the bounding box
  /// (box-like bodies then keep their faces exactly). 0: automatic, from the body and the
  /// accuracy asked for (the rule below); voxelMeshFromParticles alone uses the particle spacing.
  /// mechanics::simulate() also takes this cell (and the rule) as the CGAL mesher's target edge.
  double cell = 0.0;
  int order = 2;  ///< 1: TET4, 2: TET10
  /// The automatic cell (cell = 0) in mechanics::simulate(): thickness / elements_across, where
  /// the thickness is the smaller of the body's bounding box's shortest side and 4 V / A (V, A:
  /// its volume and surface area; BodyMeasures::thickness), but no smaller than the cell whose
  /// mesh is expected to have max_dofs degrees of freedom (mesh_size.hpp): the accuracy knob and
  /// the cost cap. TET10 defaults: 6 across puts 10 mm cells on the T-bar (60 mm sections), a
  /// CGAL mesh of ~45k dofs within ~0.5 % of finer ones; Cook's membrane (a 1 mm slab) is set by
  /// the cap instead (~0.8 mm cells, ~60 per edge). The cap keeps the single-core sparse LDLT,
  /// whose cost grows like dofs^2, inside the default 60 s time limit on 2 cores. Over particle
  /// voxels (no surface) the cell is rounded to a whole number (>= 1) of particle spacings, so
  /// that no cell is empty and a grid-sampled body keeps its faces.
  double elements_across = 6.0;
  double max_dofs = 60000.0;
};

/// Hexes whose centre lies inside the closed surface `mesh` (ray parity along x), split into
/// tetrahedra. Throws core::Error when the mesh is empty or no cell lies inside.
TetMesh voxelMeshFromSurface(const core::TriangleMesh& mesh, const VoxelMeshConfig& config);

/// Hexes of a grid aligned with the particles (origin half a cell below the lowest particle with
/// volume) that contain a particle with volume > 0. With config.cell = 0 the cell is the cube
/// root of the median particle volume (the spacing), which reproduces the cells of a
/// grid-sampled cloud. Cells over 1.5 spacings start half a spacing below the lowest particle
/// (on the particles' own cell boundaries) and hold when the particle volume in them is at least
/// half theirs, so a multiple of a grid cloud's spacing keeps its faces.
TetMesh voxelMeshFromParticles(const core::ParticleCloud& cloud, const VoxelMeshConfig& config);

/// The particles' spacing as voxelMeshFromParticles takes it: the cube root of the median volume
/// of the particles with volume > 0 (a grid sampler's spacing); 0 when none has a volume.
double medianParticleEdge(const core::ParticleCloud& cloud);

/// Whether the particles with volume form a lattice: each cell of voxelMeshFromParticles's
/// one-spacing grid holds one of them (a grid sampler's cloud). Over a random or Poisson cloud
/// many such cells are empty, so one-spacing voxels leave holes and hinges.
bool particlesFormALattice(const core::ParticleCloud& cloud);

/// Whether `point` lies inside the closed surface (parity of crossings of a ray along +x).
bool insideSurface(const core::TriangleMesh& mesh, const Eigen::Vector3d& point);

}  // namespace demnerf::mechanics
