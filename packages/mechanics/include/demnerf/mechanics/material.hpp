#pragma once
// Hyperelastic energy densities and their stresses: compressible Neo-Hookean and the
// decoupled Neo-Hookean of the Cook's membrane reference.

#include <Eigen/Core>
#include <memory>
#include <string>

#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

/// dP_iJ / dF_kL stored at (3 i + J, 3 k + L): F and P flattened row by row.
using Tangent = Eigen::Matrix<double, 9, 9>;

/// A strain energy density Psi(F) of an isotropic hyperelastic solid, per unit rest volume.
class HyperelasticMaterial {
 public:
  virtual ~HyperelasticMaterial() = default;
  /// Psi(F); +infinity when det F <= 0 so that line searches reject inverted states.
  virtual double energy(const Eigen::Matrix3d& F) const = 0;
  /// First Piola-Kirchhoff stress P = dPsi/dF.
  virtual Eigen::Matrix3d stress(const Eigen::Matrix3d& F) const = 0;
  /// dP/dF (the FEM Newton tangent).
  virtual Tangent tangent(const Eigen::Matrix3d& F) const = 0;
  virtual std::string name() const = 0;
  double mu() const { return mu_; }
  double lambda() const { return lambda_; }
  double kappa() const { return kappa_; }

 protected:
  HyperelasticMaterial(double mu, double lambda, double kappa) : mu_(mu), lambda_(lambda), kappa_(kappa) {}
  double mu_, lambda_, kappa_;
};

/// Psi = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2 (the paper's model).
class NeoHookean : public HyperelasticMaterial {
 public:
  NeoHookean(double mu, double lambda);
  double energy(const Eigen::Matrix3d& F) const override;
  Eigen::Matrix3d stress(const Eigen::Matrix3d& F) const override;
  Tangent tangent(const Eigen::Matrix3d& F) const override;
  std::string name() const override { return "neo_hookean"; }
};

/// Psi = kappa/4 (J^2 - 1 - 2 ln J) + mu/2 (J^(-2/3) I1 - 3) (deal.II Cook's membrane).
class DecoupledNeoHookean : public HyperelasticMaterial {
 public:
  DecoupledNeoHookean(double mu, double kappa);
  double energy(const Eigen::Matrix3d& F) const override;
  Eigen::Matrix3d stress(const Eigen::Matrix3d& F) const override;
  Tangent tangent(const Eigen::Matrix3d& F) const override;
  std::string name() const override { return "neo_hookean_decoupled"; }
};

/// The material a scenario names; throws core::Error for an unknown model or bad constants.
std::unique_ptr<HyperelasticMaterial> makeMaterial(const core::Material& material);

/// Cauchy stress sigma = P F^T / J.
Eigen::Matrix3d cauchyStress(const Eigen::Matrix3d& F, const Eigen::Matrix3d& P);
/// von Mises equivalent stress sqrt(3/2 s:s) of a Cauchy stress (s its deviator).
double vonMises(const Eigen::Matrix3d& sigma);

}  // namespace demnerf::mechanics
