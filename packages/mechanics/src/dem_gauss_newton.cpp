// Gauss-Newton steps for the MLP-only DEM (DemConfig::gauss_newton, issue 13). L-BFGS stalls on
// the T-bar twist at 16-17 % rel. L2 because the twist's displacement gradient is nearly all
// rotation and its strain a few per cent of it: a small error in the gradient is a large error in
// the strain, and a scalar-seeded quasi-Newton history does not resolve that (docs/
// dem_feature_grid.md). The step here is preconditioned by the metric the energy itself puts on
// the parameters, G = sum_q w_q J_q^T C J_q with J_q = dE_q/dtheta the Jacobian of the Green
// strain (a rigid rotation of the field costs nothing in it) and C the material's tangent at zero
// strain, or (gauss_newton.current_tangent) at each point's current strain; left out of the Hessian
// are the stress term S : d2E and the network's own curvature.
// The dead loads are linear in u and add nothing. The gradient and every trial energy are the
// fused kernel's on the whole cell quadrature; G is formed on a random draw of its Gauss points.
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"
#include "dem_solver_impl.hpp"
#include "exploit_guard.hpp"

namespace demnerf::mechanics {

using torch::Tensor;

namespace {

// Past this damping (relative to G's mean diagonal) the step is a tiny gradient step: stop.
constexpr double kMaxDamping = 1e8;

struct StrainMetric {
  double mu = 0.0, lambda = 0.0;  // C = lambda I (x) I + 2 mu I on symmetric strains
  double load_scale = 1.0, out_scale = 1.0, energy_scale = 1.0;
  bool current = false;  // the Neo-Hookean's tangent at each point's current strain instead
};

// Mandel components of a batch of symmetric 3 x 3 tensors [n, 3, 3] -> [n, 6]: the diagonal, then
// sqrt 2 times (0,1), (0,2), (1,2), so that a : b = mandel(a) . mandel(b).
constexpr int kMandel[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};

// The factor L^T of the Neo-Hookean's tangent at the points' current deformation gradients F
// [n, 3, 3], in Mandel form: dS/dE = lambda c (x) c + 2 (mu - lambda ln J) I_c with c = C^-1 and
// (I_c)_ijkl = (c_ik c_jl + c_il c_jk) / 2, so that dE : (dS/dE) : dE = |L^T mandel(dE)|^2. The
// self-weight block's base is compressed by 10-15 % in volume, where this is ~50 % stiffer than
// the zero-strain tangent: steps in that metric were too long (rho < 1/4, the damping climbing to
// 14 x G's mean diagonal). The factor mu - lambda ln J is kept above mu / 10 (it falls below zero
// only for J > e^(mu / lambda)), so the metric stays positive definite.
Tensor currentTangentFactor(const Tensor& F, const StrainMetric& m) {
  const Tensor Fd = F.detach().to(torch::kFloat64);
  const Tensor c = torch::linalg_inv(torch::matmul(Fd.transpose(1, 2), Fd));
  const Tensor lnJ = torch::log(torch::linalg_det(Fd).clamp_min(1e-12));
  const Tensor shear = 2.0 * (m.mu - m.lambda * lnJ).clamp_min(0.1 * m.mu);
  const long n = F.size(0);
  Tensor M = torch::zeros({n, 6, 6}, Fd.options()), cm = torch::zeros({n, 6}, Fd.options());
  for (int a = 0; a < 6; ++a) {
    const int i = kMandel[a][0], j = kMandel[a][1];
    const double sa = i == j ? 1.0 : std::sqrt(2.0);
    cm.select(1, a).copy_(sa * c.select(1, i).select(1, j));
    for (int b = 0; b < 6; ++b) {
      const int k = kMandel[b][0], l = kMandel[b][1];
      const double sb = k == l ? 1.0 : std::sqrt(2.0);
      const Tensor sym = 0.5 * (c.select(1, i).select(1, k) * c.select(1, j).select(1, l) +
                                c.select(1, i).select(1, l) * c.select(1, j).select(1, k));
      M.select(1, a).select(1, b).copy_(sa * sb * shear * sym);
    }
  }
  M += m.lambda * cm.unsqueeze(2) * cm.unsqueeze(1);
  return torch::linalg_cholesky(M).transpose(1, 2);
}

// The Jacobians of the leaves' per-point outputs r [n, k] stacked as [n, k, P] (P the parameters).
Tensor perPointJacobian(const Tensor& r, const std::vector<Tensor>& leaves) {
  const long n = r.size(0);
  std::vector<Tensor> rows;
  for (long k = 0; k < r.size(1); ++k) {
    const std::vector<Tensor> g = torch::autograd::grad({r.select(1, k).sum()}, leaves, {}, true);
    std::vector<Tensor> columns;
    for (const Tensor& gi : g) columns.push_back(gi.reshape({n, -1}));
    rows.push_back(torch::cat(columns, 1));
  }
  return torch::stack(rows, 1);
}

// The rows A of G = A^T A at the drawn points (their quadrature weights times `weight_scale`): per
// point the Jacobians of sqrt(lambda w) tr E and sqrt(2 mu w) E_ij (i <= j, off-diagonals x sqrt 2),
// so that |A d|^2 = sum_q w_q dE_q : C : dE_q, over the energy scale (the loss's units). Each
// point gets its own copy of the weights, so that autograd's gradients in them are per point.
Tensor strainJacobianRows(const DisplacementMlp& net, const Tensor& x, const Tensor (&lift)[4], const Tensor& w,
                          const StrainMetric& m) {
  const long n = x.size(0), layers = static_cast<long>(net.weights().size());
  std::vector<Tensor> leaves;
  for (long l = 0; l < layers; ++l) {
    const Tensor& W = net.weights()[l];
    leaves.push_back(W.detach().unsqueeze(0).expand({n, W.size(0), W.size(1)}).clone().requires_grad_());
    leaves.push_back(net.biases()[l].detach().unsqueeze(0).expand({n, W.size(0)}).clone().requires_grad_());
  }
  Tensor h = (x - net.center()) * net.invHalf();
  Tensor dh = torch::diag(net.invHalf().reshape({3})).unsqueeze(0).expand({n, 3, 3});  // [n, k, input]
  for (long l = 0; l + 1 < layers; ++l) {
    const Tensor& W = leaves[2 * l];
    h = torch::tanh(torch::bmm(W, h.unsqueeze(2)).squeeze(2) + leaves[2 * l + 1]);
    dh = (1 - h * h).unsqueeze(1) * torch::bmm(dh, W.transpose(1, 2));
  }
  const Tensor& Wo = leaves[2 * layers - 2];
  const Tensor z = (torch::bmm(Wo, h.unsqueeze(2)).squeeze(2) + leaves[2 * layers - 1]) * m.out_scale;
  const Tensor dz = torch::bmm(dh, Wo.transpose(1, 2)).transpose(1, 2) * m.out_scale;  // [n, i, k]
  const Tensor du = m.load_scale * lift[1] + lift[3] * z.unsqueeze(2) + lift[2].unsqueeze(2) * dz;
  const Tensor F = torch::eye(3, du.options()).unsqueeze(0) + du;
  const Tensor E = 0.5 * (torch::matmul(F.transpose(1, 2), F) - torch::eye(3, du.options()).unsqueeze(0));
  const Tensor ws = w / m.energy_scale;
  if (m.current) {
    std::vector<Tensor> e;
    for (const auto& [i, j] : kMandel) e.push_back((i == j ? 1.0 : std::sqrt(2.0)) * E.select(1, i).select(1, j));
    const Tensor L = currentTangentFactor(F, m).to(E.scalar_type()) * torch::sqrt(ws).reshape({n, 1, 1});
    return torch::bmm(L, perPointJacobian(torch::stack(e, 1), leaves)).reshape({6 * n, -1});
  }
  std::vector<Tensor> r{torch::sqrt(m.lambda * ws) * E.diagonal(0, 1, 2).sum(1)};
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      r.push_back(torch::sqrt(2 * m.mu * ws) * (i == j ? 1.0 : std::sqrt(2.0)) * E.select(1, i).select(1, j));
  std::vector<Tensor> blocks;
  for (const Tensor& rk : r) {
    const std::vector<Tensor> g = torch::autograd::grad({rk.sum()}, leaves, {}, true);
    std::vector<Tensor> columns;
    for (const Tensor& gi : g) columns.push_back(gi.reshape({n, -1}));
    blocks.push_back(torch::cat(columns, 1));
  }
  return torch::cat(blocks, 0);
}

// Every core for torch and BLAS while the steps run, unless the user pinned a count: each step is
// a few dense products and a Cholesky of the parameters' size (the strain Jacobian's rows times
// its ~2,000 columns, then G), which two threads nearly halve, unlike the small operations the
// solver's one-thread default below 50k particles is for. The solver's count comes back after.
class DenseAlgebraThreads {
 public:
  explicit DenseAlgebraThreads(int pinned) : before_(at::get_num_threads()) {
    if (pinned == 0) torch_support::setSolverThreads(torch_support::allCores(), 0);
  }
  ~DenseAlgebraThreads() { torch_support::setSolverThreads(before_, 0); }
  DenseAlgebraThreads(const DenseAlgebraThreads&) = delete;
  DenseAlgebraThreads& operator=(const DenseAlgebraThreads&) = delete;

 private:
  int before_;
};

// The parameters (weights and biases layer by layer) or their gradients as one double vector.
Tensor flatten(const DisplacementMlp& net, bool gradients) {
  std::vector<Tensor> parts;
  for (std::size_t l = 0; l < net.weights().size(); ++l)
    for (const Tensor& p : {net.weights()[l], net.biases()[l]}) parts.push_back((gradients ? p.grad() : p).reshape({-1}));
  return torch::cat(parts).to(torch::kFloat64);
}

void assign(DisplacementMlp& net, const Tensor& theta) {
  torch::NoGradGuard guard;
  long at = 0;
  for (std::size_t l = 0; l < net.weights().size(); ++l)
    for (Tensor* p : {&net.weights()[l], &net.biases()[l]}) {
      p->copy_(theta.slice(0, at, at + p->numel()).view_as(*p));
      at += p->numel();
    }
}

// The points G is formed on and their weights, which sum to the quadrature's total. Uniform: m
// distinct indices (a partial shuffle of `order`), weights rescaled to the total. Spread:
// systematic sampling on the weights' running sum from one random offset, each pick weighing
// total / m (a point heavier than that can be picked twice): every stretch of the cells' order,
// so every part of the body, is in every draw, and a cut cell's light centroid point comes up in
// proportion to its volume, not as often as a whole cell's Gauss point. The weights do not change
// between steps, so their running sum is formed once.
class MetricDraw {
 public:
  MetricDraw(const Tensor& vol, long m, bool spread) : vol_(vol), m_(m), spread_(spread), order_(vol.size(0)) {
    if (spread) {
      running_ = vol.to(torch::kFloat64).cumsum(0);
      total_ = running_[vol.size(0) - 1].item<double>();
    } else {
      total_ = vol.sum().item<double>();
    }
    std::iota(order_.begin(), order_.end(), 0L);
  }

  std::pair<Tensor, Tensor> next(std::mt19937& rng) {
    const long nq = vol_.size(0);
    if (!spread_) {
      for (long i = 0; i < m_; ++i)
        std::swap(order_[i], order_[i + std::uniform_int_distribution<long>(0, nq - 1 - i)(rng)]);
      const Tensor idx = torch::tensor(std::vector<long>(order_.begin(), order_.begin() + m_), torch::kLong);
      const Tensor w = vol_.index_select(0, idx);
      return {idx, w * (total_ / w.sum())};
    }
    const double stride = total_ / static_cast<double>(m_);
    const double offset = std::uniform_real_distribution<double>(0.0, stride)(rng);
    const Tensor at = torch::arange(m_, torch::kFloat64) * stride + offset;
    const Tensor idx = torch::searchsorted(running_, at, false, true).clamp_max(nq - 1);
    return {idx, torch::full({m_}, stride, vol_.options())};
  }

 private:
  Tensor vol_, running_;
  long m_;
  bool spread_;
  double total_ = 0.0;
  std::vector<long> order_;  ///< the uniform draw's running partial shuffle
};

// One Levenberg-Marquardt step: solves (G + mu mean(diag G) I) d = -grad and hands d and the
// model's predicted decrease to `trial`, which returns the ratio rho of the actual decrease to the
// predicted one (0: rejected, the parameters left as they were). mu falls after a step the model
// predicted well, rises after a poor one, and is raised x4 and the step retried after a rejected
// one. False when mu reached kMaxDamping without a step accepted.
template <typename Trial>
bool dampedStep(const Tensor& G, const Tensor& grad, double& damping, Trial&& trial) {
  const double diagonal = G.diagonal().mean().item<double>();
  for (;;) {
    // The damping on the diagonal in place, the factor without linalg_cholesky's checks, and two
    // triangular solves instead of cholesky_solve (10x slower for one right-hand side): a trial's
    // solve on the T-bar's 2,073 parameters 0.245 -> 0.143 CPU-s, the same d to rounding.
    Tensor M = G.clone();
    M.diagonal().add_(damping * diagonal);
    const auto [L, info] = torch::linalg_cholesky_ex(M);
    double rho = 0.0;  // a matrix the rounding left indefinite counts as a rejected step
    if (info.item<int>() == 0) {
      const Tensor y = torch::linalg_solve_triangular(L, -grad.unsqueeze(1), false);
      const Tensor d = torch::linalg_solve_triangular(L.t(), y, true).squeeze(1);
      rho = trial(d, -(grad.dot(d) + 0.5 * d.dot(torch::mv(G, d))).item<double>());
    }
    if (rho > 0) {
      damping *= rho > 0.75 ? 1.0 / 3.0 : rho < 0.25 ? 2.0 : 1.0;
      return true;
    }
    damping *= 4.0;
    if (damping >= kMaxDamping) return false;
  }
}

// When the steps stop (DemGaussNewtonConfig): converged, when the energy fell by less than
// tolerance x |E| over the last `window` steps (the energy, not the predicted decrease: G comes
// from a random draw, so one step's model is noisy, and a window of actual falls averages it);
// else at `steps`, at the solve's time limit (before a step that would likely cross it, so that the
// answer is kept and checked instead of thrown away), or when the damping ran away.
class GaussNewtonStop {
 public:
  /// `history`: the energies of the steps this run continues (their window counts, not the cap).
  GaussNewtonStop(const DemGaussNewtonConfig& c, double tolerance, double time_limit, std::vector<double> history)
      : cap_(c.steps), window_(std::max(1, c.window)), tolerance_(tolerance), time_limit_(time_limit),
        energies_(std::move(history)), before_(energies_.size()) {}

  void record(double energy) {
    energies_.push_back(energy);
    const auto now = std::chrono::steady_clock::now();
    last_step_ = std::chrono::duration<double>(now - step_start_).count();
    step_start_ = now;
  }
  /// The energy's fall over the last `window` steps relative to |E| (inf before `window` steps).
  double windowFall() const {
    const std::size_t n = energies_.size(), w = static_cast<std::size_t>(window_);
    if (n <= w) return std::numeric_limits<double>::infinity();
    return (energies_[n - 1 - w] - energies_[n - 1]) / std::max(std::abs(energies_[n - 1]), 1e-300);
  }
  /// True when no further step is to be taken; `elapsed`: the solve's seconds so far.
  bool done(bool damping_ok, double elapsed) {
    if (!damping_ok) return finish("the damping reached its limit: no step lowers the energy");
    if (steps() >= cap_) return finish("at the cap, gauss_newton.steps");
    if (tolerance_ > 0 && windowFall() < tolerance_) {
      std::ostringstream why;
      why << "converged: the energy fell by " << windowFall() << " x |E| over the last " << window_
          << " steps, below gauss_newton.tolerance";
      converged_ = true;
      return finish(why.str());
    }
    // A step costs about the last one; half more for the slower ones (rejected trials).
    if (time_limit_ > 0 && elapsed + 1.5 * last_step_ > time_limit_) return finish("stopped before the solve's time limit");
    return false;
  }
  int steps() const { return static_cast<int>(energies_.size() - before_); }
  const std::vector<double>& energies() const { return energies_; }
  const std::string& why() const { return why_; }
  bool converged() const { return converged_; }

 private:
  bool finish(std::string why) {
    why_ = std::move(why);
    return true;
  }
  int cap_, window_;
  double tolerance_, time_limit_, last_step_ = 0.0;
  bool converged_ = false;
  std::vector<double> energies_;
  std::size_t before_;
  std::chrono::steady_clock::time_point step_start_ = std::chrono::steady_clock::now();
  std::string why_;
};

}  // namespace

bool DemSolver::Impl::gaussNewtonAvailable() const {
  return fusedLossAvailable() && config.boundary.kind == DemConfig::Boundary::kExact && config.lbfgs.cell_spacings > 0;
}

// Levenberg-Marquardt Gauss-Newton steps on the cell quadrature until GaussNewtonStop says so: the
// damping mu falls after a step the model predicted well and rises after a poor or rejected one.
void DemSolver::Impl::gaussNewton(double scale, int& iterations, double tolerance, double reserve, bool resume) {
  if (!gaussNewtonAvailable())
    throw core::Error("dem.gauss_newton needs the MLP alone through the fused kernel (float32, tanh, no feature "
                      "grid, not parametric), boundary.kind exact and lbfgs.cell_spacings > 0");
  const DenseAlgebraThreads threads(config.threads);
  const JitterDraw& draw = cellDraw();
  const long m = std::min<long>(config.gauss_newton.sample, draw.x.size(0));
  const bool decoupled = scenario.material.model == "neo_hookean_decoupled";
  StrainMetric metric;
  metric.mu = material->mu();
  // The decoupled law's zero-strain tangent is kappa I (x) I + 2 mu (I - I (x) I / 3).
  metric.lambda = std::max(0.0, decoupled ? material->kappa() - 2.0 * metric.mu / 3.0 : scenario.material.lambda());
  metric.load_scale = scale;
  metric.current = config.gauss_newton.current_tangent && !decoupled;
  MetricDraw metric_draw(draw.vol, m, config.gauss_newton.spread);
  double damping = resume ? gauss_newton_resume.damping : config.gauss_newton.damping;
  // Every step is sampled: a step moves the field as much as many L-BFGS evaluations, and the
  // guard's energy (~1 fused evaluation) is small against a step. Its verdict supersedes the
  // L-BFGS's: these steps start from that state.
  ExploitGuard watchman(1, "Gauss-Newton steps");
  exploit_kept.clear();
  gauss_newton_ended.clear();
  gauss_newton_converged = false;
  GaussNewtonStop stop(config.gauss_newton, tolerance,
                       clock && control.time_limit > 0 ? std::max(control.time_limit - reserve, 1e-9) : 0.0,
                       resume ? gauss_newton_resume.energies : std::vector<double>{});
  while (!stop.done(damping < kMaxDamping, clock ? clock->elapsed() : 0.0)) {
    balanceOutput(scale);  // a no-op once balanced; GN alone starts at the a-priori amplitude
    if (watchman.due()) {
      torch::NoGradGuard no_grad;
      watchman.record(shiftedCellEnergy(scale), displacement(xv, lift_v, false, scale).first, [&] { return snapshot(); });
    }
    metric.out_scale = out_scale;
    metric.energy_scale = energy_scale;
    double energy = 0.0, jm = 0.0;
    const double e0 = fusedLoss(scale, draw, true, &energy, &jm).item<double>(), start_energy = energy;
    if (!std::isfinite(e0)) return;
    const Tensor grad = flatten(net, true), theta = flatten(net, false);
    const auto [idx, w] = metric_draw.next(rng);
    const Tensor lift[4] = {draw.lift[0].index_select(0, idx), draw.lift[1].index_select(0, idx),
                            draw.lift[2].index_select(0, idx), draw.lift[3].index_select(0, idx)};
    const Tensor A = strainJacobianRows(net, draw.x.index_select(0, idx), lift, w, metric);
    const Tensor G = torch::mm(A.t(), A).to(torch::kFloat64);
    // Until the energy falls, or the damping says the model is not to be trusted.
    const double accepted = dampedStep(G, grad, damping, [&](const Tensor& d, double predicted) {
      assign(net, theta + d);
      const double e1 = fusedLoss(scale, draw, false, &energy, &jm).item<double>();
      const double rho = (e0 - e1) / predicted;
      if (std::isfinite(e1) && rho > 0) return rho;
      assign(net, theta);
      return 0.0;
    }) ? energy : start_energy;
    stop.record(accepted);
    if (config.verbose)
      std::cerr << "dem: Gauss-Newton step " << stop.steps() << " energy " << accepted << " J, damping " << damping
                << ", fall over the window " << stop.windowFall() << " x |E|\n";
    reportProgress(++iterations);
    tick("gauss_newton", scale, iterations, accepted, std::numeric_limits<double>::quiet_NaN());
  }
  gauss_newton_ended = std::to_string(stop.steps()) + " Gauss-Newton steps (" + stop.why() + ")";
  gauss_newton_converged = stop.converged();
  gauss_newton_resume = {stop.energies(), damping};
  if (config.verbose) std::cerr << "dem: " << gauss_newton_ended << "\n";
  keepGuardedBest(watchman, scale);
}

}  // namespace demnerf::mechanics
