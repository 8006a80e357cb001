#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <memory>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/material.hpp"

namespace dm = demnerf::mechanics;
using Eigen::Matrix3d;

namespace {

std::vector<std::shared_ptr<dm::HyperelasticMaterial>> materials() {
  return {std::make_shared<dm::NeoHookean>(3.0e5, 7.0e5), std::make_shared<dm::DecoupledNeoHookean>(4.225e5, 9.15e5)};
}

// Random deformation gradients with J well above 0, stretched and sheared.
std::vector<Matrix3d> sampleF() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> d(-0.3, 0.3);
  std::vector<Matrix3d> out;
  for (int n = 0; n < 6; ++n) {
    Matrix3d F = Matrix3d::Identity();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) += d(rng);
    if (F.determinant() > 0.3) out.push_back(F);
  }
  out.push_back(Eigen::Vector3d(1.5, 0.8, 0.9).asDiagonal());
  return out;
}

TEST(Material, StressIsTheDerivativeOfTheEnergy) {
  for (const auto& m : materials())
    for (const Matrix3d& F : sampleF()) {
      const Matrix3d P = m->stress(F);
      const double h = 1e-6;
      for (int i = 0; i < 3; ++i)
        for (int J = 0; J < 3; ++J) {
          Matrix3d Fp = F, Fm = F;
          Fp(i, J) += h;
          Fm(i, J) -= h;
          const double fd = (m->energy(Fp) - m->energy(Fm)) / (2 * h);
          EXPECT_NEAR(P(i, J), fd, 1e-6 * m->mu() + 1e-6 * std::abs(fd)) << m->name() << " P(" << i << "," << J << ")";
        }
    }
}

TEST(Material, TangentIsTheDerivativeOfTheStress) {
  for (const auto& m : materials())
    for (const Matrix3d& F : sampleF()) {
      const dm::Tangent A = m->tangent(F);
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k)
        for (int L = 0; L < 3; ++L) {
          Matrix3d Fp = F, Fm = F;
          Fp(k, L) += h;
          Fm(k, L) -= h;
          const Matrix3d fd = (m->stress(Fp) - m->stress(Fm)) / (2 * h);
          for (int i = 0; i < 3; ++i)
            for (int J = 0; J < 3; ++J)
              EXPECT_NEAR(A(3 * i + J, 3 * k + L), fd(i, J), 1e-5 * m->mu()) << m->name();
        }
    }
}

TEST(Material, RestStateIsStressFreeWithLinearElasticTangent) {
  for (const auto& m : materials()) {
    const Matrix3d I = Matrix3d::Identity();
    EXPECT_NEAR(m->energy(I), 0.0, 1e-9 * m->mu());
    EXPECT_LT(m->stress(I).norm(), 1e-9 * m->mu());
    // At F = I every compressible Neo-Hookean linearises to Hooke's law with (lambda, mu).
    const dm::Tangent A = m->tangent(I);
    for (int i = 0; i < 3; ++i)
      for (int J = 0; J < 3; ++J)
        for (int k = 0; k < 3; ++k)
          for (int L = 0; L < 3; ++L) {
            const double hooke = m->lambda() * (i == J) * (k == L) + m->mu() * ((i == k) * (J == L) + (i == L) * (J == k));
            EXPECT_NEAR(A(3 * i + J, 3 * k + L), hooke, 1e-6 * m->mu()) << m->name();
          }
  }
}

TEST(Material, InvertedStatesHaveInfiniteEnergy) {
  for (const auto& m : materials()) {
    Matrix3d F = Matrix3d::Identity();
    F(2, 2) = -0.5;
    EXPECT_TRUE(std::isinf(m->energy(F)));
    F(2, 2) = 0.0;
    EXPECT_TRUE(std::isinf(m->energy(F)));
  }
}

TEST(Material, CauchyAndVonMises) {
  Matrix3d sigma = Matrix3d::Zero();
  sigma(0, 0) = -5.0;
  EXPECT_NEAR(dm::vonMises(sigma), 5.0, 1e-12);
  sigma = Matrix3d::Identity() * 3.0;
  EXPECT_NEAR(dm::vonMises(sigma), 0.0, 1e-12);
  sigma.setZero();
  sigma(0, 1) = sigma(1, 0) = 2.0;
  EXPECT_NEAR(dm::vonMises(sigma), 2.0 * std::sqrt(3.0), 1e-12);
  // sigma is symmetric for any F of a hyperelastic material.
  const dm::NeoHookean m(1.0, 2.0);
  Matrix3d F;
  F << 1.2, 0.3, 0.0, -0.1, 0.9, 0.2, 0.05, 0.0, 1.1;
  const Matrix3d s = dm::cauchyStress(F, m.stress(F));
  EXPECT_LT((s - s.transpose()).norm(), 1e-12 * s.norm());
}

TEST(Material, FactoryRejectsBadInput) {
  demnerf::core::Material mat;
  mat.model = "mooney";
  EXPECT_THROW(dm::makeMaterial(mat), demnerf::core::Error);
  mat.model = "neo_hookean";
  mat.poisson_ratio = 0.5;
  EXPECT_THROW(dm::makeMaterial(mat), demnerf::core::Error);
  mat.poisson_ratio = 0.3;
  mat.youngs_modulus = 0.0;
  EXPECT_THROW(dm::makeMaterial(mat), demnerf::core::Error);
  mat.youngs_modulus = 1e6;
  const auto m = dm::makeMaterial(mat);
  EXPECT_EQ(m->name(), "neo_hookean");
  EXPECT_NEAR(m->mu(), 1e6 / 2.6, 1e-6);
  mat.model = "neo_hookean_decoupled";
  EXPECT_NEAR(dm::makeMaterial(mat)->kappa(), 1e6 / (3 * 0.4), 1e-6);
}

}  // namespace
