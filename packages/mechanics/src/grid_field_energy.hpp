#pragma once
// The potential energy of the DEM's feature grid problem (grid_field_newton.hpp) in the grid's
// basis: value, gradient and Hessian, for the grid Newton (grid_field_newton.cpp) and the MLP-only
// DEM's equilibrium check (dem_mlp_check.cpp, gradient only).
// Private to packages/mechanics/src.
//
// Volume points are grouped by grid cell: the points of a cell share their supportSize() nodes, so
// a cell's stiffness is summed densely and scattered once. The Hessian is assembled directly in
// the Newton's unknowns (the kept nodes of the extended basis, extended_unknowns.hpp): each cell's
// stiffness is mapped through its few rows of the extension before the scatter, which costs far
// less than the global sparse product E^T H E that it replaces.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"
#include "demnerf/mechanics/material.hpp"

namespace demnerf::mechanics {

class GridFieldEnergy {
 public:
  /// Checks the problem's arrays and evaluates the basis at its points; `threads` (0: every core)
  /// run the assembly and the energy sums.
  GridFieldEnergy(const GridFieldProblem& problem, const HyperelasticMaterial& material, const BsplineGrid& grid,
                  int threads);

  /// Grid nodes some point sees: the full unknowns are 3 coefficients per active node.
  const std::vector<long>& activeNodes() const { return active_; }
  long unknowns() const { return 3 * static_cast<long>(active_.size()); }

  /// The Newton's unknowns: node_map (active nodes x reduced nodes; identity rows for kept nodes)
  /// maps them to the active nodes' coefficients; an empty map means every active node is one.
  /// Must be called before derivatives().
  void setUnknownMap(const Eigen::SparseMatrix<double>& node_map);

  /// Potential energy at full coefficients c (3 per active node); +inf when a point inverts.
  double energy(const Eigen::VectorXd& c, double* strain = nullptr, double* min_J = nullptr) const;

  /// The gradient in the full coefficients and the Hessian's lower triangle in the unknowns
  /// (setUnknownMap), at full coefficients c. With `projected`, a point's tangent dP/dF that is
  /// strongly indefinite (an eigenvalue below -0.1 mu) enters the Hessian as its nearest positive
  /// semidefinite matrix (negative eigenvalues set to zero); the others and the gradient are exact.
  void derivatives(const Eigen::VectorXd& c, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>& hessian,
                   bool projected = false) const;

  /// Per unknown node, the unknown nodes >= it that share a cell with it (the Hessian's lower
  /// pattern by node; setUnknownMap).
  const std::vector<std::vector<long>>& couplings() const { return neighbours_; }

  /// The gradient alone in the full coefficients at c: no Hessian, no setUnknownMap() needed. The
  /// MLP-only DEM's equilibrium check (dem_mlp_check.cpp) reads its first-order condition here.
  Eigen::VectorXd gradient(const Eigen::VectorXd& c) const;

  /// The volume-weighted L2 norm of the grid's share D o N c (m sqrt(m^3)); with `offset`, of the
  /// offset u_0 instead (c unused).
  double fieldNorm(const Eigen::VectorXd& c, bool offset = false) const;

  double work(const Eigen::VectorXd& c) const { return external_.dot(c) + external_offset_; }
  double externalNorm() const { return external_.norm(); }
  /// The external forces' work per full coefficient (the load vector).
  const Eigen::VectorXd& external() const { return external_; }

 private:
  /// A cell's stiffness in blocks by component pair, K[i][j](s, t) = d^2 Pi / dc_(s,i) dc_(t,j)
  /// (i >= j; the others by symmetry), and the scratch that builds them.
  struct CellStiffness;
  /// How a cell's local nodes reach the unknowns: `nodes` are the unknown nodes, and `map` (local
  /// nodes x nodes.size()) the extension's rows; an empty map means local node s is nodes[s]
  /// itself (-1: no unknown).
  struct CellReduction {
    std::vector<long> nodes;
    Eigen::MatrixXd map;
  };

  long cells() const { return static_cast<long>(cell_start_.size()) - 1; }
  void evaluateBasis();
  void buildWork();
  void buildPattern();
  void assembleCell(const Eigen::VectorXd& c, long cell, bool projected, CellStiffness& K,
                    Eigen::VectorXd& gradient) const;
  void scatter(const CellStiffness& K, const CellReduction& reduction, double* values) const;
  Eigen::Matrix3d deformationGradient(const Eigen::VectorXd& c, long q) const;
  static int rowOffset(int j, long rank, int i) { return rank == 0 ? i - j : static_cast<int>(3 - j + 3 * (rank - 1) + i); }

  const GridFieldProblem& pb_;
  const HyperelasticMaterial& material_;
  const BsplineGrid& grid_;
  const int S_;
  const int threads_;
  std::vector<long> order_, cell_start_;  // points in cell order; each cell's first point
  std::vector<long> nodes_;               // per point (in cell order) and support node
  std::vector<Eigen::Vector3d> phi_;
  std::vector<Eigen::Matrix3d> grad_phi_;  // row i: Grad phi_i
  std::vector<long> surface_nodes_;
  std::vector<Eigen::Vector3d> surface_phi_;
  std::vector<long> local_, active_;  // grid node -> active position (-1), and back
  std::vector<CellReduction> reductions_;
  std::vector<std::vector<long>> neighbours_;  // per unknown node: unknown nodes >= it it couples with
  Eigen::SparseMatrix<double> pattern_;        // lower triangle of the Hessian in the unknowns
  Eigen::VectorXd external_;
  double external_offset_ = 0.0;
  // derivatives()'s per-thread Hessian values and gradients, reused (not thread-safe: one caller).
  mutable std::vector<Eigen::VectorXd> scratch_values_, scratch_gradients_;
};

}  // namespace demnerf::mechanics
