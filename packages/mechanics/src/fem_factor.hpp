#pragma once
// The FEM tangent's direct factor. Private to packages/mechanics/src.
//
// Why two factors: a Newton tangent near equilibrium is positive definite, and there the
// supernodal Cholesky (supernodal_cholesky.hpp: dense blocks, both cores) does the work that
// Eigen's SimplicialLDLT did column by column on one core, which dominated large FEM solves
// (README: 3 factorisations were 186 of 266 s on the T-bar at 10 mm). A tangent far from
// equilibrium may be indefinite: the Cholesky refuses it and the LDL^T, which may still factor it,
// takes over exactly as before, so no solve that worked before can fail now.

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

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

  /// Factorises the lower triangle K (its pattern fixed after the first call); false when neither
  /// factor succeeds (a singular tangent).
  bool factorise(const SparseMatrix& K) {
    if (!analysed_) order(K);
    const SparseMatrix ordered = permuted(K);
    if (!analysed_) supernodal_.analyse(ordered);
    analysed_ = true;
    cholesky_ = supernodal_.factorise(ordered);
    if (cholesky_) return true;
    // Only a tangent that is not positive definite gets here: its symbolic analysis waits for it.
    if (!ldlt_analysed_) ldlt_.analyzePattern(ordered);
    ldlt_analysed_ = true;
    ldlt_.factorize(ordered);
    return ldlt_.info() == Eigen::Success;
  }

  /// K^-1 b with the last successful factorisation.
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

  SparseMatrix permuted(const SparseMatrix& K) const {
    SparseMatrix out(K.rows(), K.cols());
    out.selfadjointView<Eigen::Lower>() = K.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    return out;
  }

  SupernodalCholesky supernodal_;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt_;
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  bool pre_ordered_ = true, analysed_ = false, ldlt_analysed_ = false, cholesky_ = false;
};

}  // namespace demnerf::mechanics
