#pragma once
// What a fixture holds (docs/dem_feature_grid.md, "Fixtures hold faces"). A box fixture that
// selects one dominant, nearly flat patch of the body's surface holds that FACE: the plane fitted
// to the patch, clipped to the box, is where u is prescribed; the material under and beside it
// (the rest of the box's band) is free. The box's thickness only says where to look for the face,
// so a box a few millimetres thick (a NeRF surface is off by that much) clamps the same face as a
// razor-thin one. Sphere and halfspace regions, and boxes whose surface patch has no dominant
// face (a grip around a thin plate, a corner), keep the older meaning: the region's whole volume
// is held. The DEM (dirichlet_lift.hpp) and the FEM (fem_assembly.cpp) both go through here.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/particle_cloud.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

/// Samples of a surface patch count as one face when their outward normals lie within this
/// cosine of the face's normal (45 degrees: a box's side at 90 degrees never joins its end).
constexpr double kFaceNormalCosine = 0.7;
/// A face must carry more than this share of the patch's area, else the region's volume is held.
constexpr double kFaceAreaShare = 0.5;

/// The face a fixture holds; `valid` false means the fixture holds its region's volume.
struct HeldFace {
  bool valid = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< on the fitted plane (the face's centroid)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, outward from the body
  std::vector<Eigen::Vector3d> polygon;               ///< plane clipped to the box, in order
};

/// The largest-area cluster of surface samples whose normals agree within kFaceNormalCosine.
struct FaceCluster {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< area-weighted mean normal of the members
  std::vector<char> member;                           ///< per sample
  double share = 0.0;                                 ///< members' area / all samples' area
};
FaceCluster dominantFace(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& areas);

/// The held face of `region` from surface samples (points, unit outward normals, areas), all of
/// which the caller has found inside the region. Invalid for non-box regions, for no samples,
/// and when the dominant cluster holds no more than kFaceAreaShare of the area.
HeldFace fitHeldFace(const core::Region& region, const std::vector<Eigen::Vector3d>& points,
                     const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& areas);

/// One per fixture of the scenario (same order), fitted to the cloud's surface particles inside
/// each region.
std::vector<HeldFace> heldFaces(const core::Scenario& scenario, const core::ParticleCloud& cloud);

/// Euclidean distance from x to the face's polygon and its gradient (unit length off the polygon,
/// zero on it). `signed_across`: where x projects into the polygon, the distance is signed, negative
/// on the outer side of the face, so it continues linearly through the face instead of folding
/// back (|distance|) there (dirichletLift's signed_faces, for the MLP alone).
double heldFaceDistance(const HeldFace& face, const Eigen::Vector3d& x, Eigen::Vector3d& grad,
                        bool signed_across = false);

/// The FEM's nodes held by a fixture: with a face, every node (corners and mid-edge nodes) of the
/// boundary triangles inside the region whose normals join the face; else every node inside the
/// region. `faces` is the mesh's boundary (boundaryFaces).
std::vector<int> heldMeshNodes(const core::Region& region, const TetMesh& mesh, const std::vector<BoundaryFace>& faces);

/// The FEM's Dirichlet nodes: resolveFixtures with heldMeshNodes choosing each fixture's nodes.
/// `faces` is the mesh's boundary (boundaryFaces), which the FEM's loads use too.
Dirichlet resolveMeshFixtures(const core::Scenario& scenario, const TetMesh& mesh,
                              const std::vector<BoundaryFace>& faces);

/// The particles a fixture holds, for the solvers that constrain particles rather than a lift
/// (the DEM's penalty boundary, the PINN): a face holds its cluster's surface particles inside the
/// region, a volume every particle inside it.
Dirichlet resolveHeldParticles(const core::Scenario& scenario, const core::ParticleCloud& cloud,
                               const std::vector<HeldFace>& held);

}  // namespace demnerf::mechanics
