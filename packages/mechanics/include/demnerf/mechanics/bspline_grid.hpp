#pragma once
// A tensor-product uniform B-spline basis on a regular grid over a box: the DEM's feature grid.
//
// Each basis function is N_a(X) = b(x / h - i_a) b(y / h - j_a) b(z / h - k_a) with b the uniform
// B-spline of the grid's degree (2: C1 quadratic, 3: C2 cubic); (degree + 1)^3 of them are not zero
// at any point. Local support is what a global MLP lacks: the warping of a twisted square section
// and the boundary layer at a clamp are local features that a smooth network learns slowly.

#include <Eigen/Core>
#include <vector>

namespace demnerf::mechanics {

class BsplineGrid {
 public:
  /// Covers [lo, hi] with cubic cells of edge `cell` (the box is grown to a whole number of cells,
  /// centred). Throws core::Error for a degree other than 1, 2, 3 or a non-positive cell.
  BsplineGrid(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double cell, int degree);

  int degree() const { return degree_; }
  double cell() const { return cell_; }
  const Eigen::Vector3d& origin() const { return origin_; }
  const Eigen::Vector3i& cells() const { return cells_; }
  /// Basis functions (nodes) per axis are cells + degree.
  long nodeCount() const;
  /// Basis functions not zero at a point: (degree + 1)^3.
  int supportSize() const { return (degree_ + 1) * (degree_ + 1) * (degree_ + 1); }
  /// The cell a point lies in (points outside the box are clamped to the nearest cell).
  long cellIndex(const Eigen::Vector3d& x) const;

  /// Node indices, values and X-gradients of the supportSize() functions at x (arrays of that
  /// length). The values sum to 1 and the gradients to 0 (partition of unity) inside the box.
  void evaluate(const Eigen::Vector3d& x, long* nodes, double* values, Eigen::Vector3d* gradients) const;

 private:
  int degree_;
  double cell_;
  Eigen::Vector3d origin_;
  Eigen::Vector3i cells_;
};

}  // namespace demnerf::mechanics
