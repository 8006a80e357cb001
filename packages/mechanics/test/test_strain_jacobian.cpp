// The Gauss-Newton metric's rows by hand (strain_jacobian.hpp) against their definition: the
// Jacobians of the weighted Green strain through torch operations in float64 and autograd, as
// dem_gauss_newton.cpp formed them before (per-point copies of the weights), for the zero-strain
// and the current tangent, on one thread and on two.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <vector>

#include "../src/displacement_mlp.hpp"
#include "../src/strain_jacobian.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;

constexpr double kMu = 2.0e5, kLambda = 3.0e5, kScale = 0.8, kOutput = 0.05, kEnergyScale = 7.0;
constexpr int kMandel[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};

// dS/dE of the compressible Neo-Hookean at F [n, 3, 3] in Mandel form, its upper factor L^T.
Tensor tangentFactor(const Tensor& F) {
  const Tensor c = torch::linalg_inv(torch::matmul(F.transpose(1, 2), F));
  const Tensor shear = 2.0 * (kMu - kLambda * torch::log(torch::linalg_det(F))).clamp_min(0.1 * kMu);
  std::vector<Tensor> rows, cm;
  for (const auto& [i, j] : kMandel) {
    const double sa = i == j ? 1.0 : std::sqrt(2.0);
    cm.push_back(sa * c.select(1, i).select(1, j));
    std::vector<Tensor> row;
    for (const auto& [k, l] : kMandel) {
      const double sb = k == l ? 1.0 : std::sqrt(2.0);
      row.push_back(sa * sb * shear * 0.5 *
                    (c.select(1, i).select(1, k) * c.select(1, j).select(1, l) +
                     c.select(1, i).select(1, l) * c.select(1, j).select(1, k)));
    }
    rows.push_back(torch::stack(row, 1));
  }
  const Tensor m = torch::stack(cm, 1);
  const Tensor M = torch::stack(rows, 1) + kLambda * m.unsqueeze(2) * m.unsqueeze(1);
  return torch::linalg_cholesky(M).transpose(1, 2);
}

// The rows by autograd on a float64 network: per point, the Jacobians of sqrt(w / energy_scale)
// times L^T mandel(E) (current) or sqrt(lambda) tr E and sqrt(2 mu) E_ij (i <= j, x sqrt 2 off the
// diagonal), in the row order the kernel writes.
Tensor autogradRows(const DisplacementMlp& net, const Tensor& x, const Tensor (&lift)[4], const Tensor& w, bool current) {
  const long n = x.size(0), layers = static_cast<long>(net.weights().size());
  std::vector<Tensor> leaves;
  for (long l = 0; l < layers; ++l) {
    const Tensor& W = net.weights()[l];
    leaves.push_back(W.detach().unsqueeze(0).expand({n, W.size(0), W.size(1)}).clone().requires_grad_());
    leaves.push_back(net.biases()[l].detach().unsqueeze(0).expand({n, W.size(0)}).clone().requires_grad_());
  }
  Tensor h = (x - net.center()) * net.invHalf();
  Tensor dh = torch::diag(net.invHalf().reshape({3})).unsqueeze(0).expand({n, 3, 3});
  for (long l = 0; l + 1 < layers; ++l) {
    h = torch::tanh(torch::bmm(leaves[2 * l], h.unsqueeze(2)).squeeze(2) + leaves[2 * l + 1]);
    dh = (1 - h * h).unsqueeze(1) * torch::bmm(dh, leaves[2 * l].transpose(1, 2));
  }
  const Tensor& Wo = leaves[2 * layers - 2];
  const Tensor z = (torch::bmm(Wo, h.unsqueeze(2)).squeeze(2) + leaves[2 * layers - 1]) * kOutput;
  const Tensor dz = torch::bmm(dh, Wo.transpose(1, 2)).transpose(1, 2) * kOutput;  // [n, i, k]
  const Tensor F = torch::eye(3, x.options()).unsqueeze(0) + kScale * lift[1] + lift[3] * z.unsqueeze(2) +
                   lift[2].unsqueeze(2) * dz;
  const Tensor E = 0.5 * (torch::matmul(F.transpose(1, 2), F) - torch::eye(3, x.options()).unsqueeze(0));
  const Tensor root_w = torch::sqrt(w / kEnergyScale);
  std::vector<Tensor> e;
  for (const auto& [i, j] : kMandel) e.push_back((i == j ? 1.0 : std::sqrt(2.0)) * E.select(1, i).select(1, j));
  std::vector<Tensor> r;  // per point scalars, one per row
  if (current) {
    const Tensor Le = torch::bmm(tangentFactor(F.detach()), torch::stack(e, 1).unsqueeze(2)).squeeze(2);
    for (int a = 0; a < 6; ++a) r.push_back(root_w * Le.select(1, a));
  } else {
    r.push_back(root_w * std::sqrt(kLambda) * E.diagonal(0, 1, 2).sum(1));
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j)
        r.push_back(root_w * std::sqrt(2 * kMu) * (i == j ? 1.0 : std::sqrt(2.0)) * E.select(1, i).select(1, j));
  }
  std::vector<Tensor> blocks;
  for (const Tensor& rk : r) {
    std::vector<Tensor> columns;
    for (const Tensor& g : torch::autograd::grad({rk.sum()}, leaves, {}, true)) columns.push_back(g.reshape({n, -1}));
    blocks.push_back(torch::cat(columns, 1));
  }
  return current ? torch::stack(blocks, 1).reshape({6 * n, -1}) : torch::cat(blocks, 0);
}

class StrainJacobian : public ::testing::TestWithParam<std::tuple<bool, int>> {};

TEST_P(StrainJacobian, MatchesAutogradOfTheWeightedStrain) {
  const auto [current, threads] = GetParam();
  torch::manual_seed(3);
  const Eigen::Vector3d center(0.2, 0.05, 0.1), half(0.2, 0.05, 0.1);
  DisplacementMlp net(0, 12, 3, "tanh", center, half, torch::kFloat32);
  DisplacementMlp net64(0, 12, 3, "tanh", center, half, torch::kFloat64);
  {
    torch::NoGradGuard guard;  // the output layer starts at zero; give it a field to differentiate
    net.weights().back().copy_(0.5 * torch::randn_like(net.weights().back()));
    net.biases().back().copy_(0.2 * torch::randn_like(net.biases().back()));
    for (std::size_t l = 0; l < net.weights().size(); ++l) {
      net64.weights()[l].copy_(net.weights()[l]);
      net64.biases()[l].copy_(net.biases()[l]);
    }
  }
  const long n = 37;
  const auto f = torch::TensorOptions().dtype(torch::kFloat32);
  const Tensor x = torch::rand({n, 3}, f) * torch::tensor({0.4f, 0.1f, 0.2f});
  const Tensor lift[4] = {0.01 * torch::randn({n, 3}, f), 0.05 * torch::randn({n, 3, 3}, f),
                          0.2 + torch::rand({n, 3}, f), torch::randn({n, 3, 3}, f)};
  const Tensor w = 1e-4 * (0.5 + torch::rand({n}, f));

  mlp_kernel::Network nn;
  nn.width = 12;
  nn.depth = 3;
  for (std::size_t l = 0; l < net.weights().size(); ++l) {
    nn.weights.push_back(net.weights()[l].data_ptr<float>());
    nn.biases.push_back(net.biases()[l].data_ptr<float>());
  }
  for (int k = 0; k < 3; ++k) {
    nn.center[k] = static_cast<float>(center[k]);
    nn.inv_half[k] = static_cast<float>(1.0 / half[k]);
  }
  strain_rows::Metric metric{kMu, kLambda, kScale, kOutput, kEnergyScale, current};
  const mlp_kernel::VolumePoints points{n, x.data_ptr<float>(), w.data_ptr<float>(), nullptr,
                                        lift[0].data_ptr<float>(), lift[1].data_ptr<float>(),
                                        lift[2].data_ptr<float>(), lift[3].data_ptr<float>()};
  const long R = strain_rows::rowsPerPoint(metric), P = strain_rows::parameterCount(nn);
  ASSERT_EQ(R, current ? 6 : 7);
  ASSERT_EQ(P, 3 * 12 + 12 + 2 * (12 * 12 + 12) + 12 * 3 + 3);
  Tensor got = torch::full({n * R, P}, std::nan(""), f);
  strain_rows::strainJacobianRows(nn, metric, points, got.data_ptr<float>(), threads);

  const auto d = [](const Tensor& t) { return t.to(torch::kFloat64); };
  const Tensor lift64[4] = {d(lift[0]), d(lift[1]), d(lift[2]), d(lift[3])};
  const Tensor want = autogradRows(net64, d(x), lift64, d(w), current);
  ASSERT_EQ(want.sizes(), got.sizes());
  const double scale = want.abs().max().item<double>();
  EXPECT_GT(scale, 0.0);
  EXPECT_LT((d(got) - want).abs().max().item<double>(), 1e-5 * scale);
  // The metric they form, the part the steps see.
  const Tensor G = torch::mm(want.t(), want), Gk = torch::mm(d(got).t(), d(got));
  EXPECT_LT((Gk - G).abs().max().item<double>(), 1e-5 * G.abs().max().item<double>());
}

INSTANTIATE_TEST_SUITE_P(TangentAndThreads, StrainJacobian,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(1, 2)));

}  // namespace
}  // namespace demnerf::mechanics
