#pragma once
// A supernodal (multifrontal) sparse Cholesky for the grid Newton's Hessians (shifted_cholesky.hpp).
// Private to packages/mechanics/src.
//
// Why not Eigen's SimplicialLDLT: it eliminates one column at a time with scalar sparse updates.
// A 3-D grid's factor under nested dissection is dominated by its top separators, whose columns
// share one row structure: dense blocks of hundreds to thousands of columns. Grouped into
// supernodes they are factorised by Eigen's blocked dense kernels (LLT, triangular solve, rank-k
// update) with the same operation count: on the T-bar's 5.6k-unknown Hessian the linear solves
// (factorisations, Lanczos and CG together) took 7.3 s instead of 16.1 s (wall, loaded machine;
// docs/dem_feature_grid.md, "Supernodal factorisation and both cores"). The symbolic part (elimination tree, column counts)
// is Eigen's own analysis, kept for every factorisation of one pattern.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace demnerf::mechanics {

class SupernodalCholesky {
 public:
  /// The symbolic analysis of A's lower triangle (column-major, already in elimination order):
  /// supernodes, their row structures and the assembly tree. Returns the factorisation's operation
  /// count (sum of squared column counts, as ShiftedCholesky compares orders by).
  double analyse(const Eigen::SparseMatrix<double>& lower);

  /// L L^T = A for A with the analysed pattern (lower triangle); false when A is not positive
  /// definite (a non-positive pivot), and the factor is then unusable.
  bool factorise(const Eigen::SparseMatrix<double>& lower);

  /// A^-1 b with the last successful factorisation.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;

  /// Threads of factorise(): independent subtrees of the assembly tree (nested dissection's two
  /// halves) run side by side, the separators above them after; the factor is the same bit for bit.
  /// May come before or after analyse() (the subtrees are dealt again for the new count).
  void setThreads(int threads) {
    threads_ = threads < 1 ? 1 : threads;
    if (!parent_.empty()) splitSubtrees();
  }

  Eigen::Index rows() const { return n_; }
  /// Supernodes and the factor's stored entries (dense panels): for the verbose report and tests.
  long supernodes() const { return static_cast<long>(first_.size()) - 1; }
  double storedEntries() const;
  /// Supernodes factorised by the threads' subtrees (the rest after they join): for tests.
  long threadedSupernodes() const {
    long count = 0;
    for (int g : group_) count += g >= 0 && threads_ > 1;
    return count;
  }

 private:
  void buildSupernodes(const Eigen::VectorXi& parent, const Eigen::VectorXi& below);
  void buildStructures(const Eigen::SparseMatrix<double>& lower, const Eigen::VectorXi& parent);
  void splitSubtrees();
  bool factoriseSupernode(const Eigen::SparseMatrix<double>& lower, long s, std::vector<Eigen::MatrixXd>& updates,
                          std::vector<int>& position, std::vector<double>& front_buffer);

  Eigen::Index n_ = 0;
  std::vector<int> first_;                  // supernode s holds columns first_[s] .. first_[s + 1] - 1
  std::vector<std::vector<int>> rows_;      // its row structure: its own columns, then the rows below
  std::vector<std::vector<long>> children_;  // supernodes whose update goes to s
  std::vector<Eigen::MatrixXd> panels_;     // rows_[s].size() x width: L11 (lower) over L21
  std::vector<long> parent_;                // the supernode s's update goes to (-1: a root)
  std::vector<int> group_;                  // which thread factorises s (-1: after the threads join)
  int threads_ = 1;
};

}  // namespace demnerf::mechanics
