// A Gauss-Newton (energy natural gradient) optimiser for the paper's DEM network, against L-BFGS
// on the same network, cloud and discrete energy (issue 13, the T-bar twist). L-BFGS stalls on the
// twist because its displacement gradient is nearly all rotation and the strain a few per cent of
// it (docs/dem_feature_grid.md); a step preconditioned by the metric the energy itself puts on the
// parameters, G = sum_q w_q J_q^T C J_q with J_q = dE_q/dtheta (E the Green strain, so a rigid
// rotation costs nothing) and C the Neo-Hookean tangent at E = 0, measures the strain directly.
// Dropped from the true Hessian: the stress term S : d2E and the network's own curvature
// (Gauss-Newton). The dead loads are linear in u and add nothing. G is formed from a random draw
// of the MLP's Gauss points each step, (G + mu tr(G)/P I) d = -grad solved by Cholesky, mu set by
// Levenberg-Marquardt on the true energy's decrease against the model's.
//
// Usage: mechanics_mlp_gn key=value ...   (the keys of mechanics_mlp_fit's cloud, plus)
//   lbfgs=0 (the product's L-BFGS evaluations first, as it trains: its output balance included)
//   steps=40 (Gauss-Newton steps)  sample=1000 (Gauss points drawn for G each step)
//   damping=1e-3 (initial mu)  cpu=90 (stop after this many CPU-s)  check=1 (the product's check)
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_mlp_torch.hpp"

namespace dm = demnerf::mechanics;
namespace bench = demnerf::bench;
using namespace demnerf::bench::mlp;

namespace {

struct Problem {
  Setup su;
  Quadrature qu;
  Tensor weights, loads;  // raw Gauss weights (m^3); area x traction at the particles (N)
  double mu = 0, lambda = 0;
};

// The DEM's potential: Neo-Hookean strain energy on the cell quadrature minus the loads' work;
// +inf where a Gauss point inverts (the log of det F is undefined there).
Tensor potential(const Problem& pb, const Net& net, double s) {
  const Tensor F = torch::eye(3, torch::kFloat64).unsqueeze(0) + pb.qu.du(net, s);
  const Tensor J = torch::det(F);
  if (!(J.min().item<double>() > 0)) return torch::full({}, INFINITY, torch::kFloat64);
  const Tensor lnJ = torch::log(J);
  const Tensor psi = 0.5 * pb.mu * (F.pow(2).sum({1, 2}) - 3) - pb.mu * lnJ + 0.5 * pb.lambda * lnJ * lnJ;
  const Tensor u = pb.su.g + pb.su.D * s * net.z(pb.su.x);
  return (pb.weights * psi).sum() - (pb.loads * u).sum();
}

Tensor flat(const std::vector<Tensor>& parts) {
  std::vector<Tensor> f;
  for (const Tensor& p : parts) f.push_back(p.reshape({-1}));
  return torch::cat(f);
}

Tensor parameterVector(const Net& net) { return flat(net.parameters()).detach().clone(); }

void setParameters(Net& net, const Tensor& theta) {
  torch::NoGradGuard guard;
  long at = 0;
  for (Tensor& p : net.parameters()) {
    p.copy_(theta.slice(0, at, at + p.numel()).view_as(p));
    at += p.numel();
  }
}

// The rows A of G = A^T A at n Gauss points: per point the Jacobian of sqrt(lambda w) tr E and of
// sqrt(2 mu w) E_ij (i <= j, off-diagonals x sqrt 2), so that |A d|^2 = sum w d(E):C:d(E). Per-point
// Jacobians by autograd on a copy of the weights for each point (their gradients are per point).
Tensor gaussNewtonRows(const Problem& pb, const Net& net, double s, const Tensor& idx, double wscale) {
  const long n = idx.size(0), L = static_cast<long>(net.W.size());
  std::vector<Tensor> leaves;
  for (long l = 0; l < L; ++l) {
    leaves.push_back(net.W[l].detach().unsqueeze(0).expand({n, net.W[l].size(0), net.W[l].size(1)}).clone().requires_grad_());
    leaves.push_back(net.b[l].detach().unsqueeze(0).expand({n, net.b[l].size(0)}).clone().requires_grad_());
  }
  const Tensor x = pb.qu.x.index_select(0, idx);
  Tensor h = (x - net.center) * net.inv_half;
  Tensor dh = torch::diag(net.inv_half.squeeze(0)).unsqueeze(0).expand({n, 3, 3});  // [n, k, in]
  for (long l = 0; l + 1 < L; ++l) {
    const Tensor& W = leaves[2 * l];
    h = torch::tanh(torch::bmm(W, h.unsqueeze(2)).squeeze(2) + leaves[2 * l + 1]);
    dh = (1 - h * h).unsqueeze(1) * torch::bmm(dh, W.transpose(1, 2));
  }
  const Tensor z = torch::bmm(leaves[2 * L - 2], h.unsqueeze(2)).squeeze(2) + leaves[2 * L - 1];
  const Tensor dz = torch::bmm(dh, leaves[2 * L - 2].transpose(1, 2)).transpose(1, 2);  // [n, i, k]
  const Tensor du = pb.qu.grad_g.index_select(0, idx) + pb.qu.grad_D.index_select(0, idx) * (s * z).unsqueeze(2) +
                    pb.qu.D.index_select(0, idx).unsqueeze(2) * s * dz;
  const Tensor E = green(du), w = pb.weights.index_select(0, idx) * wscale;
  std::vector<Tensor> r{torch::sqrt(pb.lambda * w) * E.diagonal(0, 1, 2).sum(1)};
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) r.push_back(torch::sqrt(2 * pb.mu * w) * (i == j ? 1.0 : std::sqrt(2.0)) * E.select(1, i).select(1, j));
  std::vector<Tensor> blocks;
  for (const Tensor& rk : r) {
    const auto g = torch::autograd::grad({rk.sum()}, leaves, {}, true);
    std::vector<Tensor> cols;
    for (const Tensor& gi : g) cols.push_back(gi.reshape({n, -1}));
    blocks.push_back(torch::cat(cols, 1));
  }
  return torch::cat(blocks, 0);
}

// Keeps max |z| over the particles in [1/2, 2] by moving the amplitude into s (u unchanged), as the
// product's output balance does: the a-priori s is ~100x below the twist's.
void balance(Net& net, double& s, const Problem& pb) {
  torch::NoGradGuard guard;
  const double zmax = net.z(pb.su.x).abs().max().item<double>();
  if (!(zmax > 0) || (zmax > 0.5 && zmax < 2.0)) return;
  net.W.back().div_(zmax);
  net.b.back().div_(zmax);
  s *= zmax;
}

void report(const char* what, int step, const Problem& pb, const Net& net, double s, double energy, double mu,
            double cpu0) {
  torch::NoGradGuard guard;
  const Tensor u = pb.su.g + pb.su.D * s * net.z(pb.su.x);
  std::printf("%s %3d  cpu %7.2f s  rel L2 %.3f %%  energy %.6g J  mu %.3g  s %.4g\n", what, step,
              bench::processCpuSeconds() - cpu0, 100 * relL2(u, pb.su.ref), energy, mu, s);
}

// Levenberg-Marquardt Gauss-Newton steps until `steps`, the CPU budget, or a stall of mu.
void gaussNewton(Problem& pb, Net& net, double& s, const Arguments& a, double cpu0) {
  const int steps = std::stoi(text(a, "steps", "40")), sample = std::stoi(text(a, "sample", "1000"));
  const double cpu = std::stod(text(a, "cpu", "90"));
  double mu = std::stod(text(a, "damping", "1e-3"));
  torch::manual_seed(7);
  const long nq = pb.qu.x.size(0), m = std::min<long>(sample, nq);
  const double wsum = pb.weights.sum().item<double>();
  const auto dtype = text(a, "float", "0") != "0" ? torch::kFloat32 : torch::kFloat64;
  for (int step = 0; step < steps && bench::processCpuSeconds() - cpu0 < cpu && mu < 1e8; ++step) {
    balance(net, s, pb);
    for (Tensor& p : net.parameters()) p.mutable_grad() = Tensor();
    const Tensor e = potential(pb, net, s);
    const Tensor g = flat(torch::autograd::grad({e}, net.parameters()));
    const Tensor idx = torch::randperm(nq, torch::TensorOptions().dtype(torch::kLong)).slice(0, 0, m);
    const double wscale = wsum / pb.weights.index_select(0, idx).sum().item<double>();
    const double c0 = bench::processCpuSeconds();
    const Tensor A = gaussNewtonRows(pb, net, s, idx, wscale).to(dtype);
    const double c1 = bench::processCpuSeconds();
    const Tensor G = torch::mm(A.t(), A).to(torch::kFloat64);
    const double c2 = bench::processCpuSeconds();
    if (std::getenv("GN_TIMES")) std::printf("  rows %.2f s, G %.2f s\n", c1 - c0, c2 - c1);
    const double scale = G.diagonal().mean().item<double>();
    const Tensor theta = parameterVector(net);
    const double e0 = e.item<double>();
    for (;;) {
      const Tensor K = G + mu * scale * torch::eye(G.size(0), torch::kFloat64);
      const Tensor d = torch::cholesky_solve(-g.unsqueeze(1), torch::linalg_cholesky(K)).squeeze(1);
      const double predicted = -(g.dot(d) + 0.5 * d.dot(torch::mv(G, d))).item<double>();
      setParameters(net, theta + d);
      double e1;
      {
        torch::NoGradGuard guard;
        e1 = potential(pb, net, s).item<double>();
      }
      const double rho = (e0 - e1) / predicted;
      if (std::isfinite(e1) && rho > 0) {
        if (rho > 0.75) mu /= 3;
        else if (rho < 0.25) mu *= 2;
        report("GN", step + 1, pb, net, s, e1, mu, cpu0);
        break;
      }
      mu *= 4;
      setParameters(net, theta);
      if (mu > 1e8) break;
    }
  }
}

Problem problem(const Arguments& a) {
  Problem pb{setUp(a), {}, {}, {}};
  pb.qu = mlpQuadrature(pb.su);
  pb.weights = torch::tensor(pb.qu.q.weights, torch::kFloat64);
  const std::vector<Vector3d> t = dm::particleTractions(pb.su.scenario, pb.su.cloud);
  std::vector<Vector3d> f(t.size(), Vector3d::Zero());
  for (std::size_t i = 0; i < t.size(); ++i)
    if (pb.su.cloud.areas[i] > 0) f[i] = pb.su.cloud.areas[i] * t[i];
  pb.loads = rows(f);
  pb.mu = pb.su.scenario.material.mu();
  pb.lambda = pb.su.scenario.material.lambda();
  return pb;
}

}  // namespace

int main(int argc, char** argv) {
  dm::keepLargeAllocationsInHeap();
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Arguments a = bench::keyValueArguments(argc, argv);
  Problem pb = problem(a);
  dm::DemConfig config = dm::solverDefaults("mlp", text(a, "config", "")).dem;
  const double cpu0 = bench::processCpuSeconds();
  const int lbfgs = std::stoi(text(a, "lbfgs", "0"));
  config.lbfgs.iterations = lbfgs;
  dm::DemSolver dem(pb.su.cloud, pb.su.scenario, config);
  if (lbfgs > 0) {
    try {
      dem.solve();
    } catch (const std::exception& e) {
      std::printf("L-BFGS start: %s\n", e.what());
    }
  }
  const dm::DemState st = dem.state();
  Net net;
  net.center = rows({0.5 * (pb.su.lo + pb.su.hi)});
  net.inv_half = rows({(0.5 * (pb.su.hi - pb.su.lo)).cwiseInverse()});
  net.set(st);
  double s = st.output_scale;
  std::printf("%s 1/%s: %zu particles, %ld Gauss points, %ld parameters\n", pb.su.name.c_str(), text(a, "div", "10").c_str(),
              pb.su.cloud.size(), pb.qu.x.size(0), parameterVector(net).numel());
  {
    torch::NoGradGuard guard;
    report("start", 0, pb, net, s, potential(pb, net, s).item<double>(), 0, cpu0);
  }
  gaussNewton(pb, net, s, a, cpu0);
  if (text(a, "check", "1") != "0") demFromFit(pb.su, net, st, s, cpu0);
  return 0;
}
