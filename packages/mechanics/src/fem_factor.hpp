#pragma once
// The FEM tangent's direct factor. Private to packages/mechanics/src.
//
// Why two factors: a Newton tangent near equilibrium is positive definite, and there the
// supernodal Cholesky (supernodal_cholesky.hpp: dense blocks, both cores) does the work that
// Eigen's SimplicialLDLT did column by column on one core, which dominated large FEM solves
// (README: 3 factorisations were 186 of 266 s on the T-bar at 10 mm).
//
// Why a shift: a tangent far from equilibrium may be indefinite. It used to go to the LDL^T, which
// factors it on one core without supernodes: the NeRF cuboid's 127k-dof reference took 1683 s
// that way, ~500 s between Newton iterations (112.5 s shifted). Its step is not even sure to go
// downhill, which the line search needs. Newton on an energy needs a descent direction, not the
// indefinite tangent's exact inverse: K + shift |diag K| with the smallest shift of a decade
// ladder that the Cholesky accepts gives one at the Cholesky's cost (modified Newton). Near the
// answer the tangent is positive definite again and the step is Newton's own. The LDL^T stays for
// a tangent that no shift of the ladder makes positive definite.
//
// Why the ladder reaches 10^3: a bumpy mesh's small elements, far from equilibrium, can need ten
// times their diagonal. With the ladder ending at 1, a 39.6k-dof mesh of one of the render
// rostest's 152-particle NeRF cuboids, bent, sent 7 tangents to the one-core LDL^T, 25 s each:
// 190 s. Shifts of up to 10 took 24 s to the same equilibrium (-0.1601720 J both).

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>

#include "supernodal_cholesky.hpp"

namespace demnerf::mechanics {

class FemFactor {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;

  /// pre_ordered: K's dofs are already in elimination order (the mesh's nested dissection);
  /// otherwise AMD orders them. threads: of the supernodal factorisation.
  void configure(bool pre_ordered, int threads) {
    pre_ordered_ = pre_ordered;
    supernodal_.setThreads(threads);
  }

  /// Factorises the lower triangle K (its pattern fixed after the first call), or K + shift()
  /// |diag K| when K is not positive definite; false when neither that nor the LDL^T succeeds (a
  /// singular tangent).
  bool factorise(const SparseMatrix& K) {
    if (!analysed_) order(K);
    const SparseMatrix ordered = permuted(K);
    if (!analysed_) supernodal_.analyse(ordered);
    analysed_ = true;
    shift_ = 0.0;
    cholesky_ = supernodal_.factorise(ordered) || factoriseShifted(ordered);
    if (cholesky_) return true;
    // Only a tangent that no shift of the ladder helps gets here: its symbolic analysis waits for it.
    if (!ldlt_analysed_) ldlt_.analyzePattern(ordered);
    ldlt_analysed_ = true;
    ldlt_.factorize(ordered);
    return ldlt_.info() == Eigen::Success;
  }

  /// The last factorisation's shift relative to each column's |diagonal| (0: K itself).
  double shift() const { return shift_; }

  /// (K + shift() |diag K|)^-1 b with the last successful factorisation.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const {
    const Eigen::VectorXd pb = permutation_ * b;
    return permutation_.transpose() * (cholesky_ ? supernodal_.solve(pb) : Eigen::VectorXd(ldlt_.solve(pb)));
  }

  /// Stored entries of the factor (dense panels of the Cholesky, or the LDL^T's L), for reports.
  double factorEntries() const {
    return cholesky_ ? supernodal_.storedEntries() : static_cast<double>(ldlt_.matrixL().nestedExpression().nonZeros());
  }

 private:
  void order(const SparseMatrix& K) {
    if (pre_ordered_) {
      permutation_.setIdentity(K.rows());
      return;
    }
    Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> amd;
    amd.analyzePattern(K);
    permutation_ = amd.permutationP();
  }

  // The ladder starts a decade below the last shift that worked: consecutive tangents of one solve
  // are alike, so the first try usually succeeds.
  bool factoriseShifted(const SparseMatrix& ordered) {
    // (1 + 1e-9: the rungs are products of ten, 1e-4 * 10^4 lands just above 1.)
    for (double shift = last_shift_ > 0.0 ? 0.1 * last_shift_ : kFirstShift; shift <= kLastShift * (1.0 + 1e-9);
         shift *= 10.0) {
      if (supernodal_.factorise(shiftedDiagonal(ordered, shift))) {
        shift_ = last_shift_ = shift;
        return true;
      }
    }
    return false;
  }

  // K + shift |diag K|, walking the stored entries: the permuted matrix's columns need not keep
  // their rows sorted, so diagonal() (a binary search per column) cannot be relied on to find them.
  static SparseMatrix shiftedDiagonal(const SparseMatrix& K, double shift) {
    SparseMatrix out = K;
    for (Eigen::Index c = 0; c < out.outerSize(); ++c)
      for (SparseMatrix::InnerIterator it(out, c); it; ++it)
        if (it.row() == c) it.valueRef() += shift * std::abs(it.value());
    return out;
  }

  SparseMatrix permuted(const SparseMatrix& K) const {
    SparseMatrix out(K.rows(), K.cols());
    out.selfadjointView<Eigen::Lower>() = K.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    return out;
  }

  SupernodalCholesky supernodal_;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  static constexpr double kFirstShift = 1e-4, kLastShift = 1e3;
  double shift_ = 0.0, last_shift_ = 0.0;
  bool pre_ordered_ = true, analysed_ = false, ldlt_analysed_ = false, cholesky_ = false;
};

}  // namespace demnerf::mechanics
