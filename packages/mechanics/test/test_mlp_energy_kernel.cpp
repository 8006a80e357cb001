// The MLP-only DEM's hand-written loss kernel (mlp_energy_kernel.hpp) against its definition:
// the same energy built from torch operations in float64 and differentiated by autograd, for the
// exact boundary (lift g, distance D and their gradients) and the penalty one, the compressible and
// the decoupled Neo-Hookean, on point counts that leave a partly filled chunk, on one thread and on two.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <random>

#include "../src/displacement_mlp.hpp"
#include "../src/mlp_energy_kernel.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;

constexpr double kMu = 2.0e5, kLambda = 3.0e5, kKappa = 4.3e5, kScale = 0.8, kOutput = 0.01, kEnergyScale = 7.0;
// Small enough that the penalty does not drown the strain energy: with the product's 1e4 the
// penalty is ~1e6 times the energy here, and a kernel with the wrong material model still matched
// the loss and the gradients to the tolerances below.
constexpr double kPenalty = 1e-2;

struct Points {
  Tensor x, g, gg, D, gD, w, body, xs, gs, Ds, force, xc, value, mask;
};

Points randomPoints(long n, long ns, long nc) {
  torch::manual_seed(5);
  const auto f = torch::TensorOptions().dtype(torch::kFloat32);
  Points p;
  p.x = torch::rand({n, 3}, f) * torch::tensor({0.4f, 0.1f, 0.2f});
  p.g = 0.01 * torch::randn({n, 3}, f);
  p.gg = 0.02 * torch::randn({n, 3, 3}, f);
  p.D = 0.2 + torch::rand({n, 3}, f);
  p.gD = torch::randn({n, 3, 3}, f);
  p.w = 1e-4 * (0.5 + torch::rand({n}, f));
  p.body = 1e-2 * torch::randn({n, 3}, f);
  p.xs = torch::rand({ns, 3}, f) * 0.2;
  p.gs = 0.01 * torch::randn({ns, 3}, f);
  p.Ds = torch::rand({ns, 3}, f);
  p.force = torch::randn({ns, 3}, f);
  p.xc = torch::rand({nc, 3}, f) * 0.1;
  p.value = 0.01 * torch::randn({nc, 3}, f);
  p.mask = (torch::rand({nc, 3}, f) > 0.3).to(torch::kFloat32);
  return p;
}

// The loss by torch operations on a float64 copy of the network, and its parameter gradient.
double autogradLoss(const DisplacementMlp& net, const Points& p, bool exact, bool decoupled,
                    std::vector<Tensor>& grads) {
  const auto d = [](const Tensor& t) { return t.to(torch::kFloat64); };
  const Tensor c = net.center().to(torch::kFloat64), ih = net.invHalf().to(torch::kFloat64);
  DisplacementMlp net64(0, net.weights()[0].size(0), static_cast<int>(net.weights().size()) - 1, "tanh",
                        Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(), torch::kFloat64);
  {
    torch::NoGradGuard guard;
    for (std::size_t l = 0; l < net.weights().size(); ++l) {
      net64.weights()[l].copy_(net.weights()[l]);
      net64.biases()[l].copy_(net.biases()[l]);
    }
  }
  // The same normalisation: the copy was built for the unit box, so its inputs are pre-normalised.
  const auto z = [&](const Tensor& x, int order) { return net64.forward((d(x) - c) * ih, order); };
  const DisplacementMlp::Output o = z(p.x, 1);
  const Tensor dz = o.d1.transpose(1, 2) * ih.view({1, 1, 3}) * kOutput;  // [n, i, k]
  Tensor u = o.value * kOutput, gu = dz;
  if (exact) {
    gu = kScale * d(p.gg) + d(p.gD) * u.unsqueeze(2) + d(p.D).unsqueeze(2) * dz;
    u = kScale * d(p.g) + d(p.D) * u;
  }
  const Tensor F = gu + torch::eye(3, torch::kFloat64).unsqueeze(0), J = torch::det(F), lnJ = torch::log(J);
  const Tensor I1 = (F * F).sum({1, 2});
  const Tensor psi = decoupled ? 0.25 * kKappa * (J * J - 1 - 2 * lnJ) + 0.5 * kMu * (torch::pow(J, -2.0 / 3.0) * I1 - 3)
                               : 0.5 * kMu * (I1 - 3) - kMu * lnJ + 0.5 * kLambda * lnJ * lnJ;
  Tensor pi = (psi * d(p.w)).sum() - kScale * (d(p.body) * u).sum();
  Tensor us = z(p.xs, 0).value * kOutput;
  if (exact) us = kScale * d(p.gs) + d(p.Ds) * us;
  pi = pi - kScale * (d(p.force) * us).sum();
  Tensor loss = pi / kEnergyScale;
  if (!exact) {
    const Tensor r = (z(p.xc, 0).value * kOutput - kScale * d(p.value)) * d(p.mask);
    loss = loss + kPenalty * r.pow(2).sum(1).mean() / (kOutput * kOutput);
  }
  loss.backward();
  grads.clear();
  for (const Tensor& t : net64.parameters()) grads.push_back(t.grad().clone());
  return loss.item<double>();
}

double kernelLoss(const DisplacementMlp& net, const Points& p, bool exact, bool decoupled, int threads,
                  std::vector<Tensor>& grads) {
  mlp_kernel::Network nn;
  nn.width = static_cast<int>(net.weights()[0].size(0));
  nn.depth = static_cast<int>(net.weights().size()) - 1;
  mlp_kernel::Gradient g;
  grads.clear();
  for (const Tensor& t : net.parameters()) grads.push_back(torch::zeros_like(t));
  for (std::size_t l = 0; l < net.weights().size(); ++l) {
    nn.weights.push_back(net.weights()[l].data_ptr<float>());
    nn.biases.push_back(net.biases()[l].data_ptr<float>());
    g.weights.push_back(grads[2 * l].data_ptr<float>());
    g.biases.push_back(grads[2 * l + 1].data_ptr<float>());
  }
  for (int k = 0; k < 3; ++k) {
    nn.center[k] = net.center().reshape({-1})[k].item<float>();
    nn.inv_half[k] = net.invHalf()[k].item<float>();
  }
  mlp_kernel::Problem pb;
  pb.mu = kMu;
  pb.lambda = kLambda;
  pb.decoupled = decoupled;
  pb.kappa = kKappa;
  pb.load_scale = kScale;
  pb.output_scale = kOutput;
  pb.energy_scale = kEnergyScale;
  pb.volume = {p.x.size(0), p.x.data_ptr<float>(), p.w.data_ptr<float>(), p.body.data_ptr<float>()};
  pb.loads = {p.xs.size(0), p.xs.data_ptr<float>(), p.force.data_ptr<float>()};
  if (exact) {
    pb.volume.g = p.g.data_ptr<float>();
    pb.volume.grad_g = p.gg.data_ptr<float>();
    pb.volume.D = p.D.data_ptr<float>();
    pb.volume.grad_D = p.gD.data_ptr<float>();
    pb.loads.g = p.gs.data_ptr<float>();
    pb.loads.D = p.Ds.data_ptr<float>();
  } else {
    pb.penalty = {p.xc.size(0), p.xc.data_ptr<float>(), p.value.data_ptr<float>(), p.mask.data_ptr<float>(), kPenalty};
  }
  const mlp_kernel::Result r = mlp_kernel::energyAndGradient(nn, pb, &g, threads);
  EXPECT_TRUE(r.admissible);
  EXPECT_GT(r.min_J, 0.0);
  return r.loss;
}

class MlpEnergyKernel : public ::testing::TestWithParam<std::tuple<bool, bool, int>> {};

TEST_P(MlpEnergyKernel, MatchesAutogradOfTheSameEnergy) {
  const auto [exact, decoupled, threads] = GetParam();
  torch::manual_seed(11);
  DisplacementMlp net(0, 12, 3, "tanh", Eigen::Vector3d(0.2, 0.05, 0.1), Eigen::Vector3d(0.2, 0.05, 0.1),
                      torch::kFloat32);
  {
    torch::NoGradGuard guard;  // the output layer starts at zero; give it a field to differentiate
    net.weights().back().copy_(0.3 * torch::randn_like(net.weights().back()));
    net.biases().back().copy_(0.1 * torch::randn_like(net.biases().back()));
  }
  const Points p = randomPoints(203, 37, 21);  // 203 = 6 chunks of 32 and 11 points
  std::vector<Tensor> want, got;
  const double reference = autogradLoss(net, p, exact, decoupled, want);
  const double loss = kernelLoss(net, p, exact, decoupled, threads, got);
  EXPECT_NEAR(loss, reference, 2e-5 * std::abs(reference));
  ASSERT_EQ(want.size(), got.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    const double scale = want[i].abs().max().item<double>();
    const double error = (got[i].to(torch::kFloat64) - want[i]).abs().max().item<double>();
    EXPECT_LT(error, 1e-3 * scale) << "parameter tensor " << i << " (max |grad| " << scale << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(BoundaryModelAndThreads, MlpEnergyKernel,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool(), ::testing::Values(1, 2)));

}  // namespace
}  // namespace demnerf::mechanics
