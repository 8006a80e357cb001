#pragma once
// Extended B-splines for the DEM's feature grid: the coefficients of basis functions that barely
// touch the body are tied to those of a nearby cell that lies wholly inside it.
//
// Why: a grid node whose support holds only a sliver of the body (a cut corner, a sampler's thin
// surface layer) is seen by almost no quadrature weight. Its column of the Hessian is nearly zero,
// Newton needs shifted factorisations and stalls (random clouds: residual stuck at 1e-4), and where
// it does converge such nodes act as soft modes. Dropping them instead makes the body too stiff
// (13-19 % on the T-bar, docs/dem_feature_grid.md). The extension keeps the basis complete: on a
// cell inside the body the degree-p tensor B-splines span every polynomial of degree p per axis,
// and the B-spline coefficients of such a polynomial are themselves a degree-p polynomial of the
// node index. An outer node's coefficient is therefore the Lagrange extrapolation, in the index,
// of the p + 1 coefficients per axis of the inner cell's nodes: the field near the boundary is the
// polynomial continuation of the field inside (the idea of Hollig's weighted extended B-splines).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"

namespace demnerf::mechanics {

struct BsplineExtension {
  /// Positions (in the `nodes` list passed in) of the nodes that stay unknowns.
  std::vector<long> kept;
  /// nodes.size() x kept.size(): coefficient of every listed node from the kept ones (identity
  /// rows for kept nodes, extrapolation weights for the others).
  Eigen::SparseMatrix<double> map;
};

/// Per grid cell, the share of its volume that the quadrature (points, weights) puts there: the
/// `cell_fill` extendOuterNodes reads.
std::vector<double> quadratureCellFill(const BsplineGrid& grid, const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<double>& weights);

/// `nodes`: the grid nodes (ids) that carry unknowns; `cell_fill`: per grid cell, the share of its
/// volume inside the body (0-1, from the quadrature). A cell with fill >= `full` is inner; a node
/// is kept when some inner cell lies in its support, else it is extrapolated from the nearest inner
/// cell (kept as an unknown when no inner cell lies within 2 (degree + 1) cells).
BsplineExtension extendOuterNodes(const BsplineGrid& grid, const std::vector<long>& nodes,
                                  const std::vector<double>& cell_fill, double full = 0.75);

}  // namespace demnerf::mechanics
