#include "demnerf/mechanics/material.hpp"

#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

int at(int i, int J) { return 3 * i + J; }

// Adds c * Finv_Jk Finv_Li to A(iJ, kL): the derivative of F^{-T} (times -c).
void addInverseTerm(Tangent& A, const Eigen::Matrix3d& Finv, double c) {
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J)
      for (int k = 0; k < 3; ++k)
        for (int L = 0; L < 3; ++L) A(at(i, J), at(k, L)) += c * Finv(J, k) * Finv(L, i);
}

// Row-by-row flattening: v(3 i + J) = X(i, J).
Eigen::Matrix<double, 9, 1> flatten(const Eigen::Matrix3d& X) {
  Eigen::Matrix<double, 9, 1> v;
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J) v(at(i, J)) = X(i, J);
  return v;
}

// Adds c * X_iJ Y_kL to A.
void addOuter(Tangent& A, const Eigen::Matrix3d& X, const Eigen::Matrix3d& Y, double c) {
  A.noalias() += c * flatten(X) * flatten(Y).transpose();
}

}  // namespace

NeoHookean::NeoHookean(double mu, double lambda) : HyperelasticMaterial(mu, lambda, lambda + 2.0 * mu / 3.0) {}

double NeoHookean::energy(const Eigen::Matrix3d& F) const {
  const double J = F.determinant();
  if (!(J > 0.0)) return kInf;
  const double lnJ = std::log(J);
  return 0.5 * mu_ * (F.squaredNorm() - 3.0) - mu_ * lnJ + 0.5 * lambda_ * lnJ * lnJ;
}

Eigen::Matrix3d NeoHookean::stress(const Eigen::Matrix3d& F) const {
  const double J = F.determinant();
  const Eigen::Matrix3d G = F.inverse().transpose();
  return mu_ * F + (lambda_ * std::log(J) - mu_) * G;
}

Tangent NeoHookean::tangent(const Eigen::Matrix3d& F) const {
  const double lnJ = std::log(F.determinant());
  const Eigen::Matrix3d Finv = F.inverse();
  Tangent A = mu_ * Tangent::Identity();
  addOuter(A, Finv.transpose(), Finv.transpose(), lambda_);
  addInverseTerm(A, Finv, mu_ - lambda_ * lnJ);
  return A;
}

DecoupledNeoHookean::DecoupledNeoHookean(double mu, double kappa)
    : HyperelasticMaterial(mu, kappa - 2.0 * mu / 3.0, kappa) {}

double DecoupledNeoHookean::energy(const Eigen::Matrix3d& F) const {
  const double J = F.determinant();
  if (!(J > 0.0)) return kInf;
  return 0.25 * kappa_ * (J * J - 1.0 - 2.0 * std::log(J)) +
         0.5 * mu_ * (std::pow(J, -2.0 / 3.0) * F.squaredNorm() - 3.0);
}

Eigen::Matrix3d DecoupledNeoHookean::stress(const Eigen::Matrix3d& F) const {
  const double J = F.determinant();
  const Eigen::Matrix3d G = F.inverse().transpose();
  const double I1 = F.squaredNorm();
  return 0.5 * kappa_ * (J * J - 1.0) * G + mu_ * std::pow(J, -2.0 / 3.0) * (F - I1 / 3.0 * G);
}

Tangent DecoupledNeoHookean::tangent(const Eigen::Matrix3d& F) const {
  const double J = F.determinant();
  const Eigen::Matrix3d Finv = F.inverse();
  const Eigen::Matrix3d G = Finv.transpose();
  const double I1 = F.squaredNorm();
  const double s = std::pow(J, -2.0 / 3.0);
  Tangent A = Tangent::Zero();
  // Volumetric part: P = c(J) G with c = kappa/2 (J^2 - 1).
  addOuter(A, G, G, kappa_ * J * J);
  addInverseTerm(A, Finv, -0.5 * kappa_ * (J * J - 1.0));
  // Isochoric part: P = mu J^(-2/3) (F - I1/3 G).
  A += mu_ * s * Tangent::Identity();
  addOuter(A, F - I1 / 3.0 * G, G, -2.0 / 3.0 * mu_ * s);
  addOuter(A, G, F, -2.0 / 3.0 * mu_ * s);
  addInverseTerm(A, Finv, mu_ * s * I1 / 3.0);
  return A;
}

std::unique_ptr<HyperelasticMaterial> makeMaterial(const core::Material& material) {
  const double E = material.youngs_modulus, nu = material.poisson_ratio;
  if (!(E > 0.0) || !std::isfinite(E))
    throw core::Error("material youngs_modulus must be a finite value > 0 Pa, got " + std::to_string(E));
  if (!(nu > -1.0 && nu < 0.5))
    throw core::Error("material poisson_ratio must lie in (-1, 0.5), got " + std::to_string(nu));
  if (material.model == "neo_hookean") return std::make_unique<NeoHookean>(material.mu(), material.lambda());
  if (material.model == "neo_hookean_decoupled")
    return std::make_unique<DecoupledNeoHookean>(material.mu(), material.kappa());
  throw core::Error("unknown material model '" + material.model +
                    "': use neo_hookean or neo_hookean_decoupled");
}

Eigen::Matrix3d cauchyStress(const Eigen::Matrix3d& F, const Eigen::Matrix3d& P) {
  return P * F.transpose() / F.determinant();
}

double vonMises(const Eigen::Matrix3d& sigma) {
  const Eigen::Matrix3d s = sigma - sigma.trace() / 3.0 * Eigen::Matrix3d::Identity();
  return std::sqrt(1.5 * s.squaredNorm());
}

}  // namespace demnerf::mechanics
