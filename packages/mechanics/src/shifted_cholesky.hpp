#pragma once
// The feature grid Newton's linear solver (grid_field_newton.cpp, its only includer). Private to
// packages/mechanics/src.

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <limits>

namespace demnerf::mechanics {

// Solves (H + shift I) x = b with the smallest shift (0 first) that makes H positive definite.
// Newton's Hessians change little from one iteration to the next, so the last factorisation
// preconditions conjugate gradients on the new one; it is refactorised only when CG needs more
// than kMaxReuseIterations or meets negative curvature (as the FEM baseline does).
class ShiftedCholesky {
 public:
  Eigen::VectorXd solve(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& b, double initial_shift) {
    if (factorised_) {
      Eigen::VectorXd x;
      if (preconditionedCg(H, b, x)) return x;
    }
    if (!analysed_) {
      ldlt_.analyzePattern(H);
      analysed_ = true;
    }
    const double scale = std::max(H.diagonal().cwiseAbs().mean(), std::numeric_limits<double>::min());
    double shift = 0.0;
    for (int attempt = 0; attempt < 12; ++attempt) {
      Eigen::SparseMatrix<double> shifted = H;
      if (shift > 0) shifted.diagonal().array() += shift * scale;
      ldlt_.factorize(shifted);
      factorised_ = ldlt_.info() == Eigen::Success && ldlt_.vectorD().minCoeff() > 0;
      if (factorised_) return ldlt_.solve(b);
      shift = shift == 0.0 ? initial_shift : 10.0 * shift;
    }
    return b / scale;  // steepest descent as the last resort
  }

 private:
  static constexpr int kMaxReuseIterations = 30;

  bool preconditionedCg(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    x = Eigen::VectorXd::Zero(b.size());
    Eigen::VectorXd r = b, z = ldlt_.solve(r), p = z;
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
      z = ldlt_.solve(r);
      const double rz_next = r.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    return false;
  }

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt_;
  bool analysed_ = false, factorised_ = false;
};

}  // namespace demnerf::mechanics
