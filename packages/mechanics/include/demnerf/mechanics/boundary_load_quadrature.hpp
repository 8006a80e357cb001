#pragma once
// Where a load region meets a tetrahedral mesh's boundary, as quadrature points: how the FEM
// spreads a scenario's surface loads.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

struct BoundaryLoadPoint {
  int element;             ///< the element whose boundary face holds the point
  Eigen::Vector4d L;       ///< barycentric coordinates in that element
  Eigen::Vector3d x;       ///< position (m)
  double weight;           ///< area it stands for (m^2)
};

constexpr int kLoadSubdivision = 16;

/// A degree-4 rule on every boundary face the region holds whole (all its corners inside), and on
/// each of the kLoadSubdivision^2 sub-triangles of a face it cuts whose centroid it holds. So the
/// loaded patch follows the region to 1/kLoadSubdivision of an element, where whole faces chosen
/// by their centroids moved its edge (and a couple's arm) by up to half an element with the mesh.
std::vector<BoundaryLoadPoint> boundaryLoadQuadrature(const TetMesh& mesh, const std::vector<BoundaryFace>& faces,
                                                      const core::Region& region);

}  // namespace demnerf::mechanics
