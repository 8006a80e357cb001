#pragma once
// The feature grid Newton's linear solver (grid_field_newton.cpp; dem_mlp_check.cpp measures the
// MLP's residual with it). Private to packages/mechanics/src.

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <limits>
#include <vector>

namespace demnerf::mechanics {

// Solves (H + shift I) x = b with the smallest shift (0 first) that makes H positive definite.
// Newton's Hessians change little from one iteration to the next, so the last factorisation
// preconditions conjugate gradients on the new one; it is refactorised only when CG needs more
// than kMaxReuseIterations or meets negative curvature (as the FEM baseline does).
//
// The unknowns come 3 per grid node. Given the nodes' elimination order (setNodeOrder: nested
// dissection of the grid), the symbolic analysis is run for it and for Eigen's AMD, and the order
// whose factor costs fewer operations is kept. Neither wins everywhere: on one T-bar cloud AMD's
// factor held 68 % of a dense one's entries (3.3 s per factorisation, 1 s with dissection), on
// another it took 0.2 s where dissection took twice as long.
class ShiftedCholesky {
 public:
  /// Node i's dofs 3 i .. 3 i + 2 are eliminated in the order the nodes appear in `order`.
  void setNodeOrder(const std::vector<int>& order) {
    Eigen::VectorXi indices(3 * static_cast<Eigen::Index>(order.size()));
    for (std::size_t k = 0; k < order.size(); ++k)
      for (int i = 0; i < 3; ++i) indices(3 * order[k] + i) = 3 * static_cast<int>(k) + i;
    permutation_ = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>(indices);
    ordered_ = true;
  }

  Eigen::VectorXd solve(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& b, double initial_shift) {
    if (factorised_) {
      Eigen::VectorXd x;
      if (preconditionedCg(H, b, x)) return x;
    }
    const double scale = std::max(H.diagonal().cwiseAbs().mean(), std::numeric_limits<double>::min());
    // Far from the minimum (a large rotation) the Hessian stays indefinite for several iterations
    // and needs about the same shift each time: start a decade below the last one that worked
    // instead of at 0 (T-bar twist on a random cloud: 14 s of failed factorisations otherwise).
    double shift = last_shift_ > initial_shift ? 0.1 * last_shift_ : 0.0;
    for (int attempt = 0; attempt < 14; ++attempt) {
      Eigen::SparseMatrix<double> shifted = H;
      if (shift > 0) shifted.diagonal().array() += shift * scale;
      factorised_ = factorise(shifted);
      if (factorised_) {
        last_shift_ = shift;
        return factorSolve(b);
      }
      shift = shift == 0.0 ? initial_shift : 10.0 * shift;
    }
    return b / scale;  // steepest descent as the last resort
  }

 private:
  static constexpr int kMaxReuseIterations = 30;

  bool preconditionedCg(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    x = Eigen::VectorXd::Zero(b.size());
    Eigen::VectorXd r = b, z = factorSolve(r), p = z;
    double rz = r.dot(z);
    const double target = 1e-12 * b.squaredNorm();  // 1e-6 relative: an inexact Newton direction
    for (int it = 0; it < kMaxReuseIterations; ++it) {
      const Eigen::VectorXd Hp = H.selfadjointView<Eigen::Lower>() * p;
      const double curvature = p.dot(Hp);
      if (!(curvature > 0)) return false;
      const double alpha = rz / curvature;
      x += alpha * p;
      r -= alpha * Hp;
      if (r.squaredNorm() <= target) return true;
      z = factorSolve(r);
      const double rz_next = r.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    return false;
  }

  // Eigen's LDL^T with the symbolic analysis's column counts exposed: sum of squares = the
  // factorisation's operation count, up to a constant.
  template <typename Ordering>
  struct CountingLdlt : Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Ordering> {
    double operations() const { return this->m_nonZerosPerCol.template cast<double>().squaredNorm(); }
  };

  Eigen::SparseMatrix<double> permuted(const Eigen::SparseMatrix<double>& H) const {
    Eigen::SparseMatrix<double> out(H.rows(), H.cols());
    out.selfadjointView<Eigen::Lower>() = H.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    return out;
  }

  // LDL^T of the lower triangle H in the cheaper order; true when positive definite.
  bool factorise(const Eigen::SparseMatrix<double>& H) {
    Eigen::SparseMatrix<double> ordered;
    if (ordered_) ordered = permuted(H);
    if (!analysed_) {
      amd_ldlt_.analyzePattern(H);
      if (ordered_) {
        ordered_ldlt_.analyzePattern(ordered);
        ordered_ = ordered_ldlt_.operations() < amd_ldlt_.operations();
      }
      analysed_ = true;
    }
    if (ordered_) {
      ordered_ldlt_.factorize(ordered);
      return ordered_ldlt_.info() == Eigen::Success && ordered_ldlt_.vectorD().minCoeff() > 0;
    }
    amd_ldlt_.factorize(H);
    return amd_ldlt_.info() == Eigen::Success && amd_ldlt_.vectorD().minCoeff() > 0;
  }

  Eigen::VectorXd factorSolve(const Eigen::VectorXd& b) const {
    if (!ordered_) return amd_ldlt_.solve(b);
    return permutation_.transpose() * Eigen::VectorXd(ordered_ldlt_.solve(permutation_ * b));
  }

  CountingLdlt<Eigen::AMDOrdering<int>> amd_ldlt_;
  CountingLdlt<Eigen::NaturalOrdering<int>> ordered_ldlt_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  bool ordered_ = false, analysed_ = false, factorised_ = false;
  double last_shift_ = 0.0;  // relative to the mean diagonal
};

}  // namespace demnerf::mechanics
