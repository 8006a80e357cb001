#pragma once
// The feature grid Newton's linear solver (grid_field_newton.cpp; dem_mlp_check.cpp measures the
// MLP's residual with it). Private to packages/mechanics/src.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "supernodal_cholesky.hpp"

namespace demnerf::mechanics {

// Solves (H + shift |diag H|) x = b with a shift that makes H positive definite: 0 when Lanczos
// finds no negative curvature in the Jacobi-scaled S H S, else twice the most negative eigenvalue
// it estimates there (doubled while the factorisation fails).
// Newton's Hessians change little from one iteration to the next, so the last factorisation
// preconditions conjugate gradients on the new one; it is refactorised only when CG needs more
// than kMaxReuseIterations or meets negative curvature (as the FEM baseline does).
//
// The unknowns come 3 per grid node. Given the nodes' elimination order (setNodeOrder: nested
// dissection of the grid), the symbolic analysis is run for it and for Eigen's AMD, and the order
// whose factor costs fewer operations is kept. Neither wins everywhere: on one T-bar cloud AMD's
// factor held 68 % of a dense one's entries (3.3 s per factorisation, 1 s with dissection), on
// another it took 0.2 s where dissection took twice as long. A factor nearly as full as a dense
// one (a compact body) is factorised dense instead (see factorise()).
class ShiftedCholesky {
 public:
  /// Node i's dofs 3 i .. 3 i + 2 are eliminated in the order the nodes appear in `order`.
  /// Threads of the sparse factorisation (supernodal_cholesky.hpp; default 1).
  void setThreads(int threads) { supernodal_.setThreads(threads); }

  void setNodeOrder(const std::vector<int>& order) {
    Eigen::VectorXi indices(3 * static_cast<Eigen::Index>(order.size()));
    for (std::size_t k = 0; k < order.size(); ++k)
      for (int i = 0; i < 3; ++i) indices(3 * order[k] + i) = 3 * static_cast<int>(k) + i;
    permutation_ = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>(indices);
    ordered_ = true;
  }

  /// The first factorisation is tried unshifted before Lanczos, as later ones are after an
  /// unshifted one: for a Newton that starts near its minimum (the nested grid solve's fine grid).
  void tryUnshiftedFirst() { unshifted_first_ = true; }

  /// The last factorisation's shift (relative to each column's diagonal), their count, and whether they
  /// are dense (a compact body's nearly full factor): for the grid Newton's verbose report.
  double lastShift() const { return last_shift_; }
  int factorisations() const { return factorisations_; }
  /// The last solve() found H singular: it needed a shift, yet Lanczos saw no negative curvature
  /// beyond kMissedShift (grid functions the body barely sees; grid_field_newton.cpp holds them).
  bool singular() const { return singular_; }
  bool dense() const { return dense_; }
  /// Factorises H unshifted (kept for the next solve(), which then needs one CG step); true when H
  /// is positive definite. The weak hold's release asks this of the Hessian without the hold.
  bool factoriseUnshifted(const Eigen::SparseMatrix<double>& H) {
    singular_ = false;
    setScaling(H);
    factorised_ = factorise(scaledCopy(H));
    ++factorisations_;
    if (factorised_) last_shift_ = 0.0;
    return factorised_;
  }

  Eigen::VectorXd solve(const Eigen::SparseMatrix<double>& H, const Eigen::VectorXd& b, double initial_shift) {
    singular_ = false;
    if (factorised_) {
      Eigen::VectorXd x;
      if (preconditionedCg(H, b, x)) return x;
    }
    // Symmetric Jacobi scaling, S H S with unit diagonal: a grid node whose support the body barely
    // fills (a low extension fill) has a column a thousand times smaller than an inner node's. A
    // shift relative to the mean diagonal then swamps those columns (their Newton steps shrink to
    // nothing), and Lanczos, which resolves eigenvalues relative to the spectrum's width, cannot
    // see their small negative curvature: on the compressed cube at fill 0.25 it said "positive
    // definite" and the shift was found by 12 doublings from 1e-6, 12 sparse factorisations in one
    // Newton iteration. Scaled, the shift is relative to each column's own diagonal.
    const double mean = setScaling(H);
    const Eigen::SparseMatrix<double> scaled = scaledCopy(H);
    // A Hessian that needed no shift at the last factorisation usually needs none now (a Newton run
    // near its minimum): the unshifted factorisation is tried before Lanczos. It succeeds only when
    // H is positive definite, where Lanczos (Ritz values lie above the lowest eigenvalue) would
    // also have said "no shift", so the answer is the same; a failure goes on as below.
    if ((factorisations_ > 0 || unshifted_first_) && last_shift_ == 0.0) {
      factorised_ = factorise(scaled);
      ++factorisations_;
      if (factorised_) return factorSolve(b);
    }
    // The shift that makes H positive definite is about minus its most negative eigenvalue, which
    // Lanczos finds from above in a few dozen products: one or two factorisations instead of a
    // search by decades from 0 (a 30 % compression's first step took 7 factorisations, 48 s).
    // Ritz values lie above the eigenvalues, so a failed attempt doubles the shift; one Lanczos
    // missed altogether (it said positive) starts from kMissedShift.
    const double lowest = lowestEigenvalueEstimate(scaled);
    double shift = lowest > 0 ? 0.0 : std::max(initial_shift, -2.0 * lowest);
    for (int attempt = 0; attempt < 24; ++attempt) {
      Eigen::SparseMatrix<double> shifted = scaled;
      if (shift > 0) shifted.diagonal().array() += shift;
      factorised_ = factorise(shifted);
      ++factorisations_;
      if (factorised_) {
        // A shift was needed, yet the curvature Lanczos found is no more negative than the shift
        // kept for a missed estimate: a singular (not an indefinite) H.
        singular_ = shift > 0 && lowest > -kMissedShift;
        last_shift_ = shift;
        return factorSolve(b);
      }
      shift = shift == 0.0 ? std::max(initial_shift, lowest > 0 ? kMissedShift : -2.0 * lowest) : 2.0 * shift;
    }
    factorised_ = false;
    return b / mean;  // steepest descent as the last resort
  }

 private:
  static constexpr int kMaxReuseIterations = 30;
  static constexpr int kLanczosSteps = 60;
  static constexpr Eigen::Index kMaxDense = 8000;  // 512 MB as a dense matrix
  static constexpr double kDenseShare = 0.25;
  static constexpr double kMissedShift = 1e-3;  // relative to the unit diagonal of the scaled H

  // S = diag(|diag H|)^-1/2 (solve() says why); returns the mean |diag H|.
  double setScaling(const Eigen::SparseMatrix<double>& H) {
    jacobi_ = H.diagonal().cwiseAbs();
    const double mean = std::max(jacobi_.mean(), std::numeric_limits<double>::min());
    for (Eigen::Index k = 0; k < jacobi_.size(); ++k) jacobi_(k) = 1.0 / std::sqrt(std::max(jacobi_(k), 1e-14 * mean));
    return mean;
  }

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

  // S H S, S = diag(jacobi_): the lower triangle stays the lower triangle.
  Eigen::SparseMatrix<double> scaledCopy(const Eigen::SparseMatrix<double>& H) const {
    Eigen::SparseMatrix<double> out = H;
    for (int k = 0; k < out.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(out, k); it; ++it) it.valueRef() *= jacobi_(it.row()) * jacobi_(it.col());
    return out;
  }

  Eigen::SparseMatrix<double> permuted(const Eigen::SparseMatrix<double>& H) const {
    Eigen::SparseMatrix<double> out(H.rows(), H.cols());
    out.selfadjointView<Eigen::Lower>() = H.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    return out;
  }

  // Cholesky of the lower triangle H in the cheapest way; true when positive definite. A compact
  // body (a cube's grid, every node a few cells from every other) fills its sparse factor almost
  // completely, and Eigen's simplicial LDL^T then runs at a third of the blocked dense Cholesky's
  // speed (3000 unknowns: 7 s against 2 s) and cannot stop at the first negative pivot of a failed
  // shift, so a factor denser than kDenseShare of a full one is factorised dense.
  bool factorise(const Eigen::SparseMatrix<double>& H) {
    // H in the kept order, permuted once per call: the analysis and the factorisation share it
    // (on the T-bar's 14k unknowns each copy is a pass over ~4M entries).
    Eigen::SparseMatrix<double> ordered;
    if (!analysed_) {
      amd_ldlt_.analyzePattern(H);
      double sparse_ops = amd_ldlt_.operations();
      if (ordered_) {
        ordered = permuted(H);
        ordered_ldlt_.analyzePattern(ordered);
        ordered_ = ordered_ldlt_.operations() < amd_ldlt_.operations();
        sparse_ops = std::min(sparse_ops, ordered_ldlt_.operations());
      }
      // The order kept is applied explicitly; the factor itself is supernodal
      // (supernodal_cholesky.hpp: the same operations, in dense blocks).
      if (!ordered_) {
        permutation_ = amd_ldlt_.permutationP();
        ordered = Eigen::SparseMatrix<double>();
      }
      const double n = static_cast<double>(H.rows());
      dense_ = H.rows() <= kMaxDense && sparse_ops > kDenseShare * n * n * n / 3.0;
      if (!dense_) {
        if (ordered.size() == 0) ordered = permuted(H);
        supernodal_.analyse(ordered);
      }
      analysed_ = true;
    }
    if (dense_) {
      dense_llt_.compute(Eigen::MatrixXd(H));
      return dense_llt_.info() == Eigen::Success;
    }
    if (ordered.size() == 0) ordered = permuted(H);
    return supernodal_.factorise(ordered);
  }

  // (S (S H S + shift)^-1 S) b: the last factorisation's inverse in the unscaled unknowns.
  Eigen::VectorXd factorSolve(const Eigen::VectorXd& b) const {
    const Eigen::VectorXd sb = jacobi_.cwiseProduct(b);
    Eigen::VectorXd x;
    if (dense_)
      x = dense_llt_.solve(sb);
    else
      x = permutation_.transpose() * supernodal_.solve(permutation_ * sb);
    return jacobi_.cwiseProduct(x);
  }

  // The smallest Ritz value of the symmetric H (lower triangle) after kLanczosSteps steps of
  // Lanczos with full reorthogonalisation: an upper bound of its lowest eigenvalue, close to it
  // when that eigenvalue is well separated (the negative curvature of a compressed or twisted
  // state). The start vector is a fixed pseudo-random one, so solves repeat exactly.
  static double lowestEigenvalueEstimate(const Eigen::SparseMatrix<double>& H) {
    const Eigen::Index n = H.rows(), m = std::min<Eigen::Index>(kLanczosSteps, n);
    if (n == 0) return 0.0;
    Eigen::MatrixXd V(n, m);
    Eigen::VectorXd alpha(m), beta(m);
    Eigen::VectorXd v(n);
    for (Eigen::Index i = 0; i < n; ++i) v(i) = std::sin(12.9898 * static_cast<double>(i) + 1.0);
    v.normalize();
    Eigen::Index k = 0;
    while (k < m) {
      V.col(k) = v;
      Eigen::VectorXd w = H.selfadjointView<Eigen::Lower>() * v;
      alpha(k) = v.dot(w);
      for (int pass = 0; pass < 2; ++pass) w -= V.leftCols(k + 1) * (V.leftCols(k + 1).transpose() * w);
      beta(k) = w.norm();
      ++k;
      if (!(beta(k - 1) > 1e-12 * std::abs(alpha(k - 1)))) break;  // an invariant subspace: exact
      v = w / beta(k - 1);
    }
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(k, k);
    for (Eigen::Index i = 0; i < k; ++i) {
      T(i, i) = alpha(i);
      if (i + 1 < k) T(i, i + 1) = T(i + 1, i) = beta(i);
    }
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(T, Eigen::EigenvaluesOnly).eigenvalues()(0);
  }

  CountingLdlt<Eigen::AMDOrdering<int>> amd_ldlt_;
  CountingLdlt<Eigen::NaturalOrdering<int>> ordered_ldlt_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> dense_llt_;
  SupernodalCholesky supernodal_;
  Eigen::VectorXd jacobi_;  // S: the inverse square roots of |diag H| at the last factorisation
  bool ordered_ = false, analysed_ = false, factorised_ = false, dense_ = false;
  double last_shift_ = 0.0;  // relative to each column's diagonal
  int factorisations_ = 0;
  bool unshifted_first_ = false;
  bool singular_ = false;
};

}  // namespace demnerf::mechanics
