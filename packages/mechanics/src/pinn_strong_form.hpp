#pragma once
// The strong form of quasi-static equilibrium on batches, for the PINN (pinn_solver.cpp, its only
// includer): F^-1 and det F, the first Piola-Kirchhoff stress P(F) and Div P from the
// displacement's Hessian, in closed form for both Neo-Hookean models. Private to
// packages/mechanics/src.

#include <string>
#include <tuple>
#include <utility>

#include "demnerf/mechanics/material.hpp"
#include "torch_solver_support.hpp"

namespace demnerf::mechanics::pinn_strong_form {

using torch::Tensor;

// Inverse and determinant of a batch [n, 3, 3] by cross products of the rows (torch's batched
// LAPACK inverse is far slower for 3x3 blocks, and this is differentiable as it stands).
inline std::pair<Tensor, Tensor> inverse3(const Tensor& F) {
  const Tensor r0 = F.select(1, 0), r1 = F.select(1, 1), r2 = F.select(1, 2);
  const Tensor c0 = torch::cross(r1, r2, 1), c1 = torch::cross(r2, r0, 1), c2 = torch::cross(r0, r1, 1);
  const Tensor J = (r0 * c0).sum(1);
  return {torch::stack({c0, c1, c2}, 2) / J.view({-1, 1, 1}), J};
}

// First Piola-Kirchhoff stress of the scenario's material, batched; J and F^-1 returned too.
inline Tensor firstPiolaStress(const Tensor& F, Tensor& J, Tensor& Finv, const HyperelasticMaterial& material,
                               const std::string& model) {
  std::tie(Finv, J) = inverse3(F);
  const Tensor FinvT = Finv.transpose(1, 2);
  const double mu = material.mu();
  if (model == "neo_hookean_decoupled") {
    const Tensor I1 = (F * F).sum({1, 2}).view({-1, 1, 1});
    const Tensor c1 = (0.5 * material.kappa() * (J * J - 1)).view({-1, 1, 1});
    const Tensor c2 = (mu * torch::pow(J, -2.0 / 3.0)).view({-1, 1, 1});
    return c1 * FinvT + c2 * (F - I1 / 3 * FinvT);
  }
  return mu * F + (material.lambda() * torch::log(J) - mu).view({-1, 1, 1}) * FinvT;
}

// Div P [n, 3] from F, F^-1, J and the displacement Hessian H [n, i, K, J] (d2 u_i / dX_K dX_J):
// Div_i P = sum_J dP_iJ(F)[dF = H(:, :, J)], each directional derivative in closed form.
inline Tensor stressDivergence(const Tensor& F, const Tensor& Finv, const Tensor& J, const Tensor& H,
                               const HyperelasticMaterial& material, const std::string& model) {
  const Tensor FinvT = Finv.transpose(1, 2);
  // tr(F^-1 dF_J) = d ln J along X_J; sum_J (F^-1 dF_J F^-1)_Ji = -sum_J d(F^-T)_iJ.
  const Tensor dlnJ = torch::einsum("nab,nbaj->nj", {Finv, H});
  const Tensor inv_term = torch::einsum("nja,nabj->nbj", {Finv, H});
  const Tensor m = torch::einsum("nbj,nbi->ni", {inv_term, Finv});
  const Tensor lap = torch::diagonal(H, 0, 2, 3).sum(2);  // sum_J H[i, J, J]
  const double mu = material.mu();
  const auto col = [](const Tensor& s) { return s.unsqueeze(1); };
  const auto times = [](const Tensor& A, const Tensor& v) { return torch::matmul(A, v.unsqueeze(2)).squeeze(2); };
  if (model == "neo_hookean_decoupled") {
    const double kappa = material.kappa();
    const Tensor I1 = (F * F).sum({1, 2});
    const Tensor c1 = 0.5 * kappa * (J * J - 1), c2 = mu * torch::pow(J, -2.0 / 3.0);
    const Tensor dI1 = 2 * torch::einsum("nab,nabj->nj", {F, H});
    const Tensor dev = F - (I1 / 3).view({-1, 1, 1}) * FinvT;
    return col(kappa * J * J) * times(FinvT, dlnJ) - col(c1) * m - col(2.0 / 3.0 * c2) * times(dev, dlnJ) +
           col(c2) * lap - col(c2 / 3) * times(FinvT, dI1) + col(c2 * I1 / 3) * m;
  }
  const double lambda = material.lambda();
  return mu * lap + lambda * times(FinvT, dlnJ) - col(lambda * torch::log(J) - mu) * m;
}

}  // namespace demnerf::mechanics::pinn_strong_form
