#pragma once
// Tetrahedral meshes for the FEM baseline: 4-node (linear) or 10-node (quadratic) elements,
// structured meshes of (mapped) boxes, and the shape functions of both element types.

#include <Eigen/Core>
#include <array>
#include <functional>
#include <vector>

namespace demnerf::mechanics {

/// Nodes and elements. Element nodes: corners 0..3 (positive volume), then for order 2 the edge
/// midpoints of edges (0,1) (1,2) (0,2) (0,3) (1,3) (2,3); unused entries are -1.
struct TetMesh {
  int order = 1;
  std::vector<Eigen::Vector3d> nodes;
  std::vector<std::array<int, 10>> elements;
  int nodesPerElement() const { return order == 1 ? 4 : 10; }
};

/// A face on the boundary: the element it belongs to and the local corner opposite to it.
struct BoundaryFace {
  int element;
  int opposite;
};

/// Hexahedral grid of `cells` over the unit cube, each hex split into 6 tetrahedra (conforming
/// across hexes), then moved by `map` (identity when empty). Order 2 adds straight edge midpoints.
TetMesh structuredMesh(const Eigen::Vector3i& cells, int order,
                       const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& map = {});
/// structuredMesh of the box [lower, upper].
TetMesh structuredBoxMesh(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper, const Eigen::Vector3i& cells,
                          int order);
/// The 10-node version of a linear mesh (shared edge midpoints).
TetMesh elevateToQuadratic(const TetMesh& linear);
/// The mesh without its pieces that hold no node for which `held` is true. A piece is a set of
/// elements joined through shared faces: a speck of a reconstructed body that touches no fixture
/// moves freely, and one that meets the rest only at an edge or a corner turns about that hinge;
/// either makes the stiffness singular or nearly so. (A two-tetrahedron piece hinged on a bump of
/// the NeRF T-bar's Poisson 1/6 cloud's CGAL mesh held the FEM's Newton at 5e-5 of the load, at
/// every load step.) Nodes are renumbered; a mesh with no held piece is returned unchanged (the
/// solver then reports the missing support itself).
TetMesh keepHeldPieces(const TetMesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& held);
/// The volume of the mesh's tetrahedra (from their corners: a TET10's edges are straight).
double tetMeshVolume(const TetMesh& mesh);
/// Faces that belong to exactly one element.
std::vector<BoundaryFace> boundaryFaces(const TetMesh& mesh);

/// Shape functions of an element of `order` at barycentric coordinates L (L sums to 1).
Eigen::VectorXd tetShape(int order, const Eigen::Vector4d& L);
/// Their derivatives with respect to the four barycentric coordinates (n x 4).
Eigen::MatrixXd tetShapeDerivatives(int order, const Eigen::Vector4d& L);
/// Barycentric coordinates of x in the tetrahedron of corners c (may be negative outside).
Eigen::Vector4d barycentric(const std::array<Eigen::Vector3d, 4>& c, const Eigen::Vector3d& x);
/// d L / d X (4 x 3) of a straight-sided tetrahedron; its volume goes to `volume`.
Eigen::Matrix<double, 4, 3> barycentricGradients(const std::array<Eigen::Vector3d, 4>& c, double* volume);

}  // namespace demnerf::mechanics
