// The grid Newton's linear solver (src/shifted_cholesky.hpp) on Hessians like a cut-cell grid's:
// most columns of one scale, a few (nodes whose support the body barely fills) a thousand times
// smaller. Their negative curvature must be found and shifted away in the columns' own scale.
#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <vector>

#include "../src/shifted_cholesky.hpp"

namespace demnerf::mechanics {
namespace {

// Lower triangle of a 1-D Laplacian (2, -1) on `n` unknowns followed by `tiny_pairs` 2 x 2 blocks
// eps [[1, c], [c, 1]], each weakly tied to the chain: eigenvalues eps (1 +/- c), negative for c > 1.
Eigen::SparseMatrix<double> chainWithTinyColumns(int n, int tiny_pairs, double eps, double c) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i + 1 < n) t.emplace_back(i + 1, i, -1.0);
  }
  for (int k = 0; k < tiny_pairs; ++k) {
    const int a = n + 2 * k, b = a + 1;
    t.emplace_back(a, a, eps);
    t.emplace_back(b, b, eps);
    t.emplace_back(b, a, c * eps);
    t.emplace_back(a, 37 * k % n, 0.01 * eps);  // row a, column < a: lower triangle
  }
  Eigen::SparseMatrix<double> H(n + 2 * tiny_pairs, n + 2 * tiny_pairs);
  for (auto& e : t)
    if (e.row() < e.col()) e = Eigen::Triplet<double>(e.col(), e.row(), e.value());
  H.setFromTriplets(t.begin(), t.end());
  return H;
}

Eigen::VectorXd rightHandSide(Eigen::Index n) {
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) b(i) = std::cos(0.37 * static_cast<double>(i)) + 0.5;
  return b;
}

TEST(ShiftedCholesky, FindsTheNegativeCurvatureOfNearlyEmptyColumns) {
  // The tiny columns' negative eigenvalue (-1e-4) is 1/40000 of the chain's spectrum: unscaled,
  // Lanczos did not see it and the shift was found by doublings from 1e-6 (8 factorisations).
  const Eigen::SparseMatrix<double> H = chainWithTinyColumns(2000, 3, 1e-4, 2.0);
  const Eigen::VectorXd b = rightHandSide(H.rows());
  ShiftedCholesky solver;
  const Eigen::VectorXd x = solver.solve(H, b, 1e-6);
  EXPECT_LE(solver.factorisations(), 2);
  EXPECT_GT(solver.lastShift(), 0.0);
  EXPECT_GT(b.dot(x), 0.0);  // a descent direction for the gradient -b
  // x solves (H + shift |diag H|) x = b: the shift scales each column by its own diagonal, so the
  // tiny columns' steps are as large as their curvature allows, not swamped by the chain's scale.
  Eigen::SparseMatrix<double> shifted = H;
  shifted.diagonal() += solver.lastShift() * H.diagonal().cwiseAbs();
  const Eigen::VectorXd r = b - shifted.selfadjointView<Eigen::Lower>() * x;
  EXPECT_LT(r.norm(), 1e-8 * b.norm());
  const Eigen::Index tiny = H.rows() - 1;
  EXPECT_GT(std::abs(x(tiny)), 10.0 * std::abs(b(tiny)));  // a step of order b / eps, not b / 2
}

TEST(ShiftedCholesky, SolvesAPositiveDefiniteBadlyScaledSystemExactly) {
  const Eigen::SparseMatrix<double> H = chainWithTinyColumns(500, 4, 1e-6, 0.5);
  const Eigen::VectorXd b = rightHandSide(H.rows());
  ShiftedCholesky solver;
  const Eigen::VectorXd x = solver.solve(H, b, 1e-6);
  EXPECT_EQ(solver.factorisations(), 1);
  EXPECT_EQ(solver.lastShift(), 0.0);
  const Eigen::VectorXd r = b - H.selfadjointView<Eigen::Lower>() * x;
  EXPECT_LT(r.norm(), 1e-9 * b.norm());
}


// After an unshifted factorisation the next one is tried unshifted before Lanczos; when the new
// Hessian is indefinite that attempt fails and the shift must still be found as on a first call.
TEST(ShiftedCholesky, AnIndefiniteHessianAfterAPositiveOneIsStillShifted) {
  const Eigen::SparseMatrix<double> positive = chainWithTinyColumns(2000, 3, 1e-4, 0.5);
  const Eigen::SparseMatrix<double> indefinite = chainWithTinyColumns(2000, 3, 1e-4, 2.0);
  const Eigen::VectorXd b = rightHandSide(positive.rows());
  ShiftedCholesky solver;
  solver.solve(positive, b, 1e-6);
  ASSERT_EQ(solver.lastShift(), 0.0);
  const Eigen::VectorXd x = solver.solve(indefinite, b, 1e-6);
  EXPECT_GT(solver.lastShift(), 0.0);
  EXPECT_GT(b.dot(x), 0.0);
  Eigen::SparseMatrix<double> shifted = indefinite;
  shifted.diagonal() += solver.lastShift() * indefinite.diagonal().cwiseAbs();
  EXPECT_LT((b - shifted.selfadjointView<Eigen::Lower>() * x).norm(), 1e-8 * b.norm());
}

}  // namespace
}  // namespace demnerf::mechanics
