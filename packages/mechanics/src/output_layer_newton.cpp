#include "demnerf/mechanics/output_layer_newton.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <limits>

namespace demnerf::mechanics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The problem with its per-component basis Phi_i (3n x M): row 3 p + k holds
// d u_i / d X_k at point p per unit of W(i, .), so Grad u(i, k) = Phi_i.row(3 p + k) . W.row(i).
class OutputLayerEnergy {
 public:
  OutputLayerEnergy(const OutputLayerProblem& problem, const HyperelasticMaterial& material)
      : pb_(problem), material_(material), n_(problem.h.rows()), m_(problem.h.cols()) {
    const double c = problem.output_scale;
    for (int i = 0; i < 3; ++i) {
      phi_[i].resize(3 * n_, m_);
      for (Eigen::Index p = 0; p < n_; ++p)
        for (int k = 0; k < 3; ++k)
          phi_[i].row(3 * p + k) = c * (problem.grad_D(p, 3 * i + k) * problem.h.row(p) +
                                        problem.D(p, i) * problem.dh.row(3 * p + k));
      // External work per unit of W(i, .): body force on the volume points, traction on the surface.
      const double s = problem.load_scale;
      external_[i] = s * c *
                     (problem.h.transpose() * problem.body.col(i).cwiseProduct(problem.D.col(i)) +
                      problem.surface_h.transpose() *
                          problem.traction_area.col(i).cwiseProduct(problem.surface_D.col(i)));
      external_lift_ += s * s *
                        (problem.body.col(i).dot(problem.g.col(i)) +
                         problem.traction_area.col(i).dot(problem.surface_g.col(i)));
    }
  }

  Eigen::Index unknowns() const { return 3 * m_; }

  Eigen::Matrix3d deformationGradient(const std::array<Eigen::VectorXd, 3>& grad_u, Eigen::Index p) const {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) F(i, k) += pb_.load_scale * pb_.grad_g(p, 3 * i + k) + grad_u[i](3 * p + k);
    return F;
  }

  std::array<Eigen::VectorXd, 3> gradients(const Eigen::MatrixXd& W) const {
    std::array<Eigen::VectorXd, 3> g;
    for (int i = 0; i < 3; ++i) g[i] = phi_[i] * W.row(i).transpose();
    return g;
  }

  /// Potential energy; +inf when a particle inverts. Also reports the internal part and min det F.
  double energy(const Eigen::MatrixXd& W, double* strain = nullptr, double* min_J = nullptr) const {
    const auto grad_u = gradients(W);
    double internal = 0.0, jmin = kInf;
    for (Eigen::Index p = 0; p < n_; ++p) {
      const Eigen::Matrix3d F = deformationGradient(grad_u, p);
      jmin = std::min(jmin, F.determinant());
      internal += pb_.volume(p) * material_.energy(F);
    }
    double work = external_lift_;
    for (int i = 0; i < 3; ++i) work += external_[i].dot(W.row(i).transpose());
    if (strain) *strain = internal;
    if (min_J) *min_J = jmin;
    return std::isfinite(internal) ? internal - work : kInf;
  }

  /// Gradient (3M, component-major) and Hessian (3M x 3M) of the energy at W.
  void derivatives(const Eigen::MatrixXd& W, Eigen::VectorXd& gradient, Eigen::MatrixXd& hessian) const {
    const auto grad_u = gradients(W);
    std::array<Eigen::VectorXd, 3> r;
    for (auto& v : r) v.resize(3 * n_);
    std::vector<Tangent> A(n_);
    for (Eigen::Index p = 0; p < n_; ++p) {
      const Eigen::Matrix3d F = deformationGradient(grad_u, p);
      const Eigen::Matrix3d P = material_.stress(F);
      A[p] = pb_.volume(p) * material_.tangent(F);
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) r[i](3 * p + k) = pb_.volume(p) * P(i, k);
    }
    gradient.resize(3 * m_);
    hessian.resize(3 * m_, 3 * m_);
    Eigen::MatrixXd Y(3 * n_, m_);
    for (int i = 0; i < 3; ++i) {
      gradient.segment(i * m_, m_) = phi_[i].transpose() * r[i] - external_[i];
      for (int j = i; j < 3; ++j) {
        // Y.row(3p + k) = sum_l A_p(3i + k, 3j + l) Phi_j.row(3p + l)
        for (Eigen::Index p = 0; p < n_; ++p)
          Y.middleRows(3 * p, 3).noalias() = A[p].block<3, 3>(3 * i, 3 * j) * phi_[j].middleRows(3 * p, 3);
        hessian.block(i * m_, j * m_, m_, m_).noalias() = phi_[i].transpose() * Y;
        if (j != i) hessian.block(j * m_, i * m_, m_, m_) = hessian.block(i * m_, j * m_, m_, m_).transpose();
      }
    }
  }

 private:
  const OutputLayerProblem& pb_;
  const HyperelasticMaterial& material_;
  Eigen::Index n_, m_;
  std::array<Eigen::MatrixXd, 3> phi_;
  std::array<Eigen::VectorXd, 3> external_;
  double external_lift_ = 0.0;
};

// W (3 x M) <-> a component-major vector.
Eigen::VectorXd flatten(const Eigen::MatrixXd& W) {
  Eigen::VectorXd v(W.size());
  for (Eigen::Index i = 0; i < W.rows(); ++i) v.segment(i * W.cols(), W.cols()) = W.row(i).transpose();
  return v;
}
Eigen::MatrixXd unflatten(const Eigen::VectorXd& v, Eigen::Index cols) {
  Eigen::MatrixXd W(3, cols);
  for (int i = 0; i < 3; ++i) W.row(i) = v.segment(i * cols, cols).transpose();
  return W;
}

// Solves (H + shift I) x = b with the smallest shift (0 first) that makes it positive definite.
Eigen::VectorXd regularisedSolve(const Eigen::MatrixXd& H, const Eigen::VectorXd& b, double initial_shift) {
  const double scale = std::max(H.diagonal().cwiseAbs().mean(), std::numeric_limits<double>::min());
  double shift = 0.0;
  for (int attempt = 0; attempt < 20; ++attempt) {
    Eigen::LLT<Eigen::MatrixXd> llt(H + shift * scale * Eigen::MatrixXd::Identity(H.rows(), H.cols()));
    if (llt.info() == Eigen::Success) return llt.solve(b);
    shift = shift == 0.0 ? initial_shift : 10.0 * shift;
  }
  return b / scale;  // steepest descent as the last resort
}

}  // namespace

OutputLayerNewtonOutcome minimiseOutputLayer(const OutputLayerProblem& problem, const HyperelasticMaterial& material,
                                             Eigen::MatrixXd& W, const OutputLayerNewtonConfig& config) {
  const OutputLayerEnergy energy(problem, material);
  OutputLayerNewtonOutcome out;
  double strain = 0.0;
  double current = energy.energy(W, &strain, &out.min_J);
  if (!std::isfinite(current)) {
    // The start inverts particles (a larger load fraction than the network was trained for):
    // the lift alone (W = 0) is admissible whenever the prescribed displacements are.
    Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(W.rows(), W.cols());
    current = energy.energy(zero, &strain, &out.min_J);
    if (!std::isfinite(current)) {
      out.energy = current;
      return out;
    }
    W = zero;
  }
  Eigen::VectorXd gradient;
  Eigen::MatrixXd hessian;
  for (int it = 0; it < config.max_iterations; ++it) {
    energy.derivatives(W, gradient, hessian);
    const Eigen::VectorXd step = regularisedSolve(hessian, -gradient, config.initial_shift);
    const double decrement = -gradient.dot(step);
    if (!(decrement > config.tolerance * std::max(std::abs(current), strain))) {
      out.converged = std::isfinite(decrement);
      break;
    }
    // Backtracking (Armijo) line search; inverted states have infinite energy and are rejected.
    const Eigen::VectorXd w = flatten(W);
    bool moved = false;
    for (double alpha = 1.0; alpha > 1e-6; alpha *= 0.5) {
      Eigen::MatrixXd trial = unflatten(w + alpha * step, W.cols());
      double trial_strain = 0.0, trial_J = 0.0;
      const double e = energy.energy(trial, &trial_strain, &trial_J);
      if (std::isfinite(e) && e <= current - 1e-4 * alpha * decrement) {
        W = std::move(trial);
        current = e;
        strain = trial_strain;
        out.min_J = trial_J;
        moved = true;
        break;
      }
    }
    ++out.iterations;
    if (!moved) break;
  }
  out.energy = current;
  return out;
}

}  // namespace demnerf::mechanics
