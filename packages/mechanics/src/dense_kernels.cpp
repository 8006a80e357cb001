// Built with -march=native when DEMNERF_MECHANICS_NATIVE is on (packages/mechanics/CMakeLists.txt).
// Eigen is renamed in this TU: its templates and inline functions are instantiated here under
// flags the rest of the library does not share, and the linker keeps one copy of each name, so
// under its own name no instantiation is shared (an AVX-512 copy of a function the rest of the
// library calls, or the other way round, with different alignment assumptions).
#define Eigen DemnerfNativeEigen
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "dense_kernels.hpp"

namespace demnerf::mechanics::dense {

bool factorFront(double* front, int m, int w) {
  Eigen::Map<Eigen::MatrixXd> F(front, m, m);
  // In place: the factor overwrites A11's lower triangle.
  Eigen::Ref<Eigen::MatrixXd> a11 = F.topLeftCorner(w, w);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(a11);
  if (llt.info() != Eigen::Success) return false;
  if (m == w) return true;
  auto below = F.bottomLeftCorner(m - w, w);
  F.topLeftCorner(w, w).triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(below);
  F.bottomRightCorner(m - w, m - w).selfadjointView<Eigen::Lower>().rankUpdate(below, -1.0);
  return true;
}

void panelForward(const double* panel, int m, int w, double* y1, double* part) {
  const Eigen::Map<const Eigen::MatrixXd> P(panel, m, w);
  Eigen::Map<Eigen::VectorXd> y(y1, w);
  P.topRows(w).triangularView<Eigen::Lower>().solveInPlace(y);
  if (m > w) Eigen::Map<Eigen::VectorXd>(part, m - w).noalias() = P.bottomRows(m - w) * y;
}

void panelBackward(const double* panel, int m, int w, const double* part, double* y1) {
  const Eigen::Map<const Eigen::MatrixXd> P(panel, m, w);
  Eigen::Map<Eigen::VectorXd> y(y1, w);
  if (m > w) y.noalias() -= P.bottomRows(m - w).transpose() * Eigen::Map<const Eigen::VectorXd>(part, m - w);
  P.topRows(w).triangularView<Eigen::Lower>().transpose().solveInPlace(y);
}

void cellStiffness(const double* const G[3], const double* tangents, long n, int S, double* scratch,
                   double* const K[6]) {
  using Tangent = Eigen::Matrix<double, 9, 9>;
  Eigen::Map<Eigen::MatrixXd> H(scratch, 3 * n, S);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Map<const Eigen::MatrixXd> Gi(G[i], S, 3 * n);
    for (int j = 0; j <= i; ++j) {
      const Eigen::Map<const Eigen::MatrixXd> Gj(G[j], S, 3 * n);
      for (long k = 0; k < n; ++k) {
        const Eigen::Map<const Tangent> A(tangents + 81 * k);
        H.middleRows<3>(3 * k).noalias() = A.block<3, 3>(3 * i, 3 * j) * Gj.middleCols<3>(3 * k).transpose();
      }
      Eigen::Map<Eigen::MatrixXd>(K[i * (i + 1) / 2 + j], S, S).noalias() = Gi * H;
    }
  }
}

void reduceBlock(const double* E, int S, int r, const double* K, double* scratch, double* out) {
  const Eigen::Map<const Eigen::MatrixXd> Em(E, S, r);
  Eigen::Map<Eigen::MatrixXd> KE(scratch, S, r);
  KE.noalias() = Eigen::Map<const Eigen::MatrixXd>(K, S, S) * Em;
  Eigen::Map<Eigen::MatrixXd>(out, r, r).noalias() = Em.transpose() * KE;
}

}  // namespace demnerf::mechanics::dense
