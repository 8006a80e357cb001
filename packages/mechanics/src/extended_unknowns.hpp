#pragma once
// The unknowns of the feature grid's Newton solve (grid_field_newton.cpp) and of the MLP-only
// DEM's equilibrium check (dem_mlp_check.cpp):
// the full coefficient vector, or the kept nodes of the extended B-spline basis with the map to
// the full one. Private to packages/mechanics/src.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cmath>
#include <vector>

#include "demnerf/mechanics/bspline_extension.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"

namespace demnerf::mechanics {

/// The grid Newton's unknowns: every active node's coefficients, or (GridNewtonConfig::extension_fill)
/// only the kept nodes', the others extrapolated from them (c = E r, bspline_extension.hpp).
class Unknowns {
 public:
  Unknowns(const GridFieldProblem& problem, const BsplineGrid& grid, const std::vector<long>& active, double fill) {
    if (!(fill > 0)) return;
    const BsplineExtension ext =
        extendOuterNodes(grid, active, quadratureCellFill(grid, problem.points, problem.volume), fill);
    std::vector<Eigen::Triplet<double>> entries;
    for (int k = 0; k < ext.map.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(ext.map, k); it; ++it)
        for (int i = 0; i < 3; ++i)
          entries.emplace_back(3 * static_cast<int>(it.row()) + i, 3 * static_cast<int>(it.col()) + i, it.value());
    map_.resize(3 * ext.map.rows(), 3 * ext.map.cols());
    map_.setFromTriplets(entries.begin(), entries.end());
    node_map_ = ext.map;
    kept_ = ext.kept;
    extended_ = true;
  }
  bool extended() const { return extended_; }
  Eigen::VectorXd full(const Eigen::VectorXd& r) const { return extended_ ? Eigen::VectorXd(map_ * r) : r; }
  /// The unknowns of full coefficients: the kept nodes' values.
  Eigen::VectorXd reduce(const Eigen::VectorXd& c) const {
    if (!extended_) return c;
    Eigen::VectorXd r(map_.cols());
    for (std::size_t k = 0; k < kept_.size(); ++k) r.segment<3>(3 * k) = c.segment<3>(3 * kept_[k]);
    return r;
  }
  /// The gradient in the unknowns (E^T g).
  Eigen::VectorXd projectGradient(const Eigen::VectorXd& gradient) const {
    return extended_ ? Eigen::VectorXd(map_.transpose() * gradient) : gradient;
  }
  /// The position in the active list of unknown node r.
  long activeOfUnknown(long r) const { return extended_ ? kept_[r] : r; }
  /// Active nodes x kept nodes (bspline_extension.hpp); empty when every active node is an unknown.
  const Eigen::SparseMatrix<double>& nodeMap() const { return node_map_; }

 private:
  bool extended_ = false;
  std::vector<long> kept_;           // positions in the active list of the kept nodes
  Eigen::SparseMatrix<double> map_;  // 3 x active nodes by 3 x kept nodes
  Eigen::SparseMatrix<double> node_map_;
};

}  // namespace demnerf::mechanics
