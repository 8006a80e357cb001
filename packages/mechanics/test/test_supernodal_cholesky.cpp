// The supernodal Cholesky (src/supernodal_cholesky.hpp) that replaced Eigen's SimplicialLDLT in the
// grid Newton's linear solver: same answers as the simplicial factor it replaced, on matrices with
// a grid Hessian's structure (3 unknowns per node, 27-node stencils, nested-dissection-like order),
// and a refusal, not a wrong factor, when the matrix is not positive definite.
#include <gtest/gtest.h>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <vector>

#include "../src/fem_factor.hpp"
#include "../src/supernodal_cholesky.hpp"

namespace demnerf::mechanics {
namespace {

// Lower triangle of a symmetric matrix on an nx x ny x nz node lattice, 3 unknowns per node, every
// pair of nodes within one lattice step coupled (a quadratic B-spline grid's pattern is wider, the
// structure the same). Off-diagonal values are deterministic pseudo-random; the diagonal is
// `diagonal` times the row's absolute sum (> 1: positive definite; < 1 with a negative entry: not).
Eigen::SparseMatrix<double> latticeMatrix(int nx, int ny, int nz, double diagonal, bool one_negative_pivot = false) {
  const auto id = [&](int x, int y, int z) { return (z * ny + y) * nx + x; };
  const int n = 3 * nx * ny * nz;
  std::vector<Eigen::Triplet<double>> t;
  std::vector<double> row_sum(n, 0.0);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int X = x + dx, Y = y + dy, Z = z + dz;
              if (X < 0 || Y < 0 || Z < 0 || X >= nx || Y >= ny || Z >= nz) continue;
              const int a = id(x, y, z), b = id(X, Y, Z);
              if (b < a) continue;
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) {
                  const int r = 3 * b + j, c = 3 * a + i;
                  if (r <= c) continue;
                  const double v = std::sin(0.731 * r + 1.37 * c);
                  t.emplace_back(r, c, v);
                  row_sum[r] += std::abs(v);
                  row_sum[c] += std::abs(v);
                }
            }
  for (int k = 0; k < n; ++k) t.emplace_back(k, k, diagonal * row_sum[k] + 1e-3);
  if (one_negative_pivot) t.emplace_back(n / 2, n / 2, -2.0 * (diagonal * row_sum[n / 2] + 1e-3));
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

Eigen::VectorXd rightHandSide(Eigen::Index n) {
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) b(i) = std::cos(0.37 * static_cast<double>(i)) + 0.25;
  return b;
}

TEST(SupernodalCholesky, SolvesAsTheSimplicialFactorItReplaced) {
  for (const auto& size : std::vector<Eigen::Vector3i>{{1, 1, 1}, {5, 4, 3}, {9, 8, 7}}) {
    const Eigen::SparseMatrix<double> A = latticeMatrix(size(0), size(1), size(2), 1.05);
    const Eigen::VectorXd b = rightHandSide(A.rows());
    SupernodalCholesky supernodal;
    supernodal.analyse(A);
    ASSERT_TRUE(supernodal.factorise(A));
    const Eigen::VectorXd x = supernodal.solve(b);
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> simplicial(A);
    ASSERT_EQ(simplicial.info(), Eigen::Success);
    const Eigen::VectorXd reference = simplicial.solve(b);
    EXPECT_LT((x - reference).norm(), 1e-10 * reference.norm()) << size.transpose();
    EXPECT_LT((A.selfadjointView<Eigen::Lower>() * x - b).norm(), 1e-10 * b.norm());
    if (A.rows() > 3) EXPECT_LT(supernodal.supernodes(), A.rows() / 3 + 1);  // a node's 3 unknowns join
  }
}

TEST(SupernodalCholesky, RefactorisesNewValuesOnTheAnalysedPattern) {
  const Eigen::SparseMatrix<double> A = latticeMatrix(6, 5, 4, 1.05);
  SupernodalCholesky supernodal;
  supernodal.analyse(A);
  ASSERT_TRUE(supernodal.factorise(A));
  Eigen::SparseMatrix<double> B = A;
  B.diagonal() *= 3.0;  // same pattern, other values: the factor must follow them
  ASSERT_TRUE(supernodal.factorise(B));
  const Eigen::VectorXd b = rightHandSide(B.rows());
  EXPECT_LT((B.selfadjointView<Eigen::Lower>() * supernodal.solve(b) - b).norm(), 1e-10 * b.norm());
}

// Independent subtrees are factorised on threads: the factor must be the serial one bit for bit,
// and a non-positive pivot inside a thread's subtree must still be reported.
// In AMD's order (a bushy tree, like nested dissection's; the lattice's natural order is a chain).
Eigen::SparseMatrix<double> amdOrdered(const Eigen::SparseMatrix<double>& lower) {
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> p;
  Eigen::AMDOrdering<int>()(Eigen::SparseMatrix<double>(lower.selfadjointView<Eigen::Lower>()), p);
  Eigen::SparseMatrix<double> out(lower.rows(), lower.cols());
  out.selfadjointView<Eigen::Lower>() = lower.selfadjointView<Eigen::Lower>().twistedBy(p.inverse());
  // The permuted columns' rows are unsorted, which Eigen's selfadjoint product (the residual
  // below) does not allow; a round trip through row-major storage sorts them.
  return Eigen::SparseMatrix<double>(Eigen::SparseMatrix<double, Eigen::RowMajor>(out));
}

TEST(SupernodalCholesky, FactorisesTheSameOnThreads) {
  const Eigen::SparseMatrix<double> A = amdOrdered(latticeMatrix(9, 8, 7, 1.05));
  const Eigen::VectorXd b = rightHandSide(A.rows());
  SupernodalCholesky serial;
  serial.analyse(A);
  ASSERT_TRUE(serial.factorise(A));
  const Eigen::VectorXd x = serial.solve(b);
  for (int threads : {2, 3}) {
    SupernodalCholesky parallel;
    parallel.setThreads(threads);
    parallel.analyse(A);
    ASSERT_TRUE(parallel.factorise(A));
    EXPECT_GT(parallel.threadedSupernodes(), parallel.supernodes() / 2);
    EXPECT_EQ((parallel.solve(b) - x).cwiseAbs().maxCoeff(), 0.0) << threads << " threads";
    EXPECT_LT((A.selfadjointView<Eigen::Lower>() * x - b).norm(), 1e-10 * b.norm());
    const Eigen::SparseMatrix<double> indefinite = amdOrdered(latticeMatrix(9, 8, 7, 1.05, true));
    EXPECT_FALSE(parallel.factorise(indefinite));
  }
}

TEST(SupernodalCholesky, RefusesAMatrixThatIsNotPositiveDefinite) {
  const Eigen::SparseMatrix<double> A = latticeMatrix(6, 5, 4, 1.05, true);
  SupernodalCholesky supernodal;
  supernodal.analyse(A);
  EXPECT_FALSE(supernodal.factorise(A));
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> simplicial(A);
  EXPECT_LT(simplicial.vectorD().minCoeff(), 0.0);  // the old path's test says the same
}

// The FEM's factor (src/fem_factor.hpp): the supernodal Cholesky where the tangent is positive
// definite, in the mesh's order or AMD's; a shifted Cholesky where it is not (a descent step for
// the Newton); the LDL^T where no shift of the ladder helps. `shift` returns the factor's shift.
double factorResidual(const Eigen::SparseMatrix<double>& A, bool pre_ordered, double* shift = nullptr,
                      double* descent = nullptr) {
  FemFactor factor;
  factor.configure(pre_ordered, 2);
  if (!factor.factorise(A)) return -1.0;
  Eigen::VectorXd b(A.rows());
  for (Eigen::Index i = 0; i < b.size(); ++i) b(i) = std::cos(0.37 * static_cast<double>(i));
  const Eigen::VectorXd x = factor.solve(b);
  if (shift) *shift = factor.shift();
  if (descent) *descent = b.dot(x);  // > 0: -x goes downhill along a gradient b
  Eigen::SparseMatrix<double> factored = A;
  factored.diagonal() += factor.shift() * A.diagonal().cwiseAbs();
  return (factored.selfadjointView<Eigen::Lower>() * x - b).norm() / b.norm();
}

TEST(FemFactor, SolvesAPositiveDefiniteTangentInEitherOrder) {
  const Eigen::SparseMatrix<double> A = latticeMatrix(7, 6, 5, 1.2);
  EXPECT_GE(factorResidual(A, true), 0.0);
  EXPECT_LT(factorResidual(A, true), 1e-10);
  EXPECT_GE(factorResidual(A, false), 0.0);
  EXPECT_LT(factorResidual(A, false), 1e-10);
}

TEST(FemFactor, ShiftsAnIndefiniteTangentIntoADescentStep) {
  // Positive diagonal, too small for the couplings: indefinite as a tangent far from equilibrium is.
  const Eigen::SparseMatrix<double> A = latticeMatrix(6, 5, 4, 0.35);
  SupernodalCholesky cholesky;
  cholesky.analyse(A);
  ASSERT_FALSE(cholesky.factorise(A));  // the Cholesky alone refuses it
  for (bool pre_ordered : {true, false}) {
    double shift = 0.0, descent = 0.0;
    const double residual = factorResidual(A, pre_ordered, &shift, &descent);
    EXPECT_GE(residual, 0.0) << "no factor of an indefinite but regular tangent";
    EXPECT_LT(residual, 1e-10) << "the factor is not of A + shift |diag A|";
    EXPECT_GT(shift, 0.0);
    EXPECT_LE(shift, 1.0);
    EXPECT_GT(descent, 0.0) << "the shifted step does not go downhill";
  }
}

TEST(FemFactor, FallsBackToLdltWhereNoShiftOfTheLadderHelps) {
  // Couplings with an all but zero diagonal (1e-3 against row sums of ~20): even the ladder's top
  // rung, a thousand times |diag|, leaves it indefinite.
  const Eigen::SparseMatrix<double> A = latticeMatrix(6, 5, 4, 0.0);
  double shift = 1.0;
  const double residual = factorResidual(A, true, &shift);
  EXPECT_GE(residual, 0.0) << "the LDL^T fallback did not factor a regular tangent";
  EXPECT_LT(residual, 1e-8);
  EXPECT_EQ(shift, 0.0) << "the LDL^T factors the tangent itself";
}

TEST(FemFactor, ShiftsANegativeDefiniteTangentIntoADescentStepToo) {
  // Far from equilibrium a bumpy mesh's small elements can need ten times their diagonal; a
  // negative definite tangent is the extreme case, and it still gets a descent step from the
  // Cholesky (the LDL^T's Newton step would go uphill, and on one core).
  const Eigen::SparseMatrix<double> A = -latticeMatrix(6, 5, 4, 1.2);
  double shift = 0.0, descent = 0.0;
  const double residual = factorResidual(A, true, &shift, &descent);
  EXPECT_GE(residual, 0.0);
  EXPECT_LT(residual, 1e-10);
  EXPECT_GT(shift, 1.0);
  EXPECT_GT(descent, 0.0) << "the shifted step does not go downhill";
}

}  // namespace
}  // namespace demnerf::mechanics
