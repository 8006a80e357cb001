// The one translation unit of the PINN baseline that includes LibTorch.
#include "demnerf/mechanics/pinn_solver.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>
#include <thread>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/material.hpp"
#include "adaptive_load_steps.hpp"
#include "torch_solver_support.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;
using torch_support::keepLargeAllocationsInHeap;
using torch_support::setBlasThreads;
using torch_support::toTensor;
using torch_support::toVectors;

// Unordered index pairs (k <= m) of the symmetric Hessian, and the slot of each (k, m).
const long kPairK[6] = {0, 0, 0, 1, 1, 2};
const long kPairM[6] = {0, 1, 2, 1, 2, 2};
const long kPairOf[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};

// Inverse and determinant of a batch [n, 3, 3] by cross products of the rows (torch's batched
// LAPACK inverse is far slower for 3x3 blocks, and this is differentiable as it stands).
std::pair<Tensor, Tensor> inverse3(const Tensor& F) {
  const Tensor r0 = F.select(1, 0), r1 = F.select(1, 1), r2 = F.select(1, 2);
  const Tensor c0 = torch::cross(r1, r2, 1), c1 = torch::cross(r2, r0, 1), c2 = torch::cross(r0, r1, 1);
  const Tensor J = (r0 * c0).sum(1);
  return {torch::stack({c0, c1, c2}, 2) / J.view({-1, 1, 1}), J};
}

}  // namespace

struct PinnSolver::Impl {
  core::ParticleCloud cloud;
  core::Scenario scenario;
  PinnConfig config;
  std::unique_ptr<HyperelasticMaterial> material;
  torch::Dtype dtype = torch::kFloat32;
  double length = 1.0;       // body size L (largest bounding-box extent)
  double out_scale = 1.0;    // displacement the network's unit output stands for (m)
  double stress_scale = 1.0;  // mu * out_scale / L: the expected stress (Pa)
  std::vector<Tensor> weights, biases;
  Tensor center_t, inv_half, eye3, pair_k, pair_m, hessian_slots;
  // Residual particles (volume > 0) with the mask of the components not prescribed there;
  // traction particles (area > 0) with normal, full-load traction and free mask; fixed particles.
  Tensor xr, free_r, xs, normal_s, traction_s, free_s, xc, fixed_value, fixed_mask;
  Tensor vol_r, body_r, area_s, cell_r;  // cell_r: edge of each residual particle's cell, [n, 1]  // quadrature weights for the reported energy
  double fraction = 0.0;
  // The running solve's clock (null: no budget, no reports) and when it last got a report.
  SolveClock* clock = nullptr;
  double last_report = -1e300;

  // Stops the solve (SolveError) when the caller's budget is spent or it cancelled; the caller
  // restores the last converged load step's network.
  void check() const {
    if (!clock) return;
    std::ostringstream state;
    state << "the network at load fraction " << fraction;
    clock->check(state.str());
  }
  // One progress line at most once a second (the CLI's interval); the energy pass costs about one loss
  // evaluation, so it runs only when a report is due. The residual column stays NaN: the
  // PINN's loss is a mean of squared strong-form residuals, not |r| / |f_ext|.
  void progress(const char* phase, double scale, int iteration) {
    if (!clock) return;
    const double now = clock->elapsed();
    if (now - last_report < 1.0) return;
    last_report = now;
    SolveProgress line;
    line.phase = phase;
    line.load_fraction = scale;
    line.iteration = iteration;
    line.energy = energy(scale);
    line.residual = std::numeric_limits<double>::quiet_NaN();
    clock->report(line);
  }
  bool rescaled = false;

  std::vector<Tensor> parameters() const {
    std::vector<Tensor> p;
    for (std::size_t l = 0; l < weights.size(); ++l) {
      p.push_back(weights[l]);
      p.push_back(biases[l]);
    }
    return p;
  }

  // sigma(a) and its first two derivatives (s2 only when asked).
  void activate(const Tensor& a, Tensor& h, Tensor& s1, Tensor* s2) const {
    if (config.activation == "sin") {
      h = torch::sin(a);
      s1 = torch::cos(a);
      if (s2) *s2 = -h;
    } else if (config.activation == "softplus") {
      h = torch::softplus(a);
      s1 = torch::sigmoid(a);
      if (s2) *s2 = s1 * (1 - s1);
    } else {
      h = torch::tanh(a);
      s1 = 1 - h * h;
      if (s2) *s2 = -2 * h * s1;
    }
  }

  // Network output z [n, 3], and by forward-mode propagation through the layers (order >= 1)
  // dz [n, k, i] = d z_i / d X_k and (order 2) d2z [n, p, i] = d2 z_i / dX_k dX_m for the six
  // pairs p = (k <= m). Forward mode costs one extra matmul per derivative slot and stays
  // differentiable for the parameter gradient, where nested reverse passes would cost more.
  struct NetOut {
    Tensor z, dz, d2z;
  };
  NetOut network(const Tensor& x, int order) const {
    Tensor h = (x - center_t) * inv_half, dh, d2h;
    const std::size_t L = weights.size();
    for (std::size_t l = 0; l < L; ++l) {
      Tensor a = torch::addmm(biases[l], h, weights[l].t()), da, d2a;
      if (order >= 1) {
        // The first layer's input derivative is constant: W scaled by the normalisation.
        da = l == 0 ? (weights[0].t() * inv_half.unsqueeze(1)).unsqueeze(0) : torch::matmul(dh, weights[l].t());
        if (order >= 2 && l > 0) d2a = torch::matmul(d2h, weights[l].t());
      }
      if (l + 1 == L) {
        if (order >= 1 && l == 0) da = da.expand({x.size(0), 3, a.size(1)});
        if (order >= 2 && l == 0) d2a = torch::zeros({x.size(0), 6, a.size(1)}, a.options());
        return {a, da, d2a};
      }
      Tensor s1, s2;
      activate(a, h, s1, order >= 2 ? &s2 : nullptr);
      if (order >= 1) {
        const Tensor s1u = s1.unsqueeze(1);
        if (order >= 2) {
          d2h = s2.unsqueeze(1) * da.index_select(1, pair_k) * da.index_select(1, pair_m);
          if (l > 0) d2h = d2h + s1u * d2a;
        }
        dh = s1u * da;
      }
    }
    return {h, dh, d2h};
  }

  // First Piola-Kirchhoff stress of the scenario's material, batched; J and F^-1 returned too.
  Tensor stress(const Tensor& F, Tensor& J, Tensor& Finv) const {
    std::tie(Finv, J) = inverse3(F);
    const Tensor FinvT = Finv.transpose(1, 2);
    const double mu = material->mu();
    if (scenario.material.model == "neo_hookean_decoupled") {
      const Tensor I1 = (F * F).sum({1, 2}).view({-1, 1, 1});
      const Tensor c1 = (0.5 * material->kappa() * (J * J - 1)).view({-1, 1, 1});
      const Tensor c2 = (mu * torch::pow(J, -2.0 / 3.0)).view({-1, 1, 1});
      return c1 * FinvT + c2 * (F - I1 / 3 * FinvT);
    }
    return mu * F + (material->lambda() * torch::log(J) - mu).view({-1, 1, 1}) * FinvT;
  }

  // Div P [n, 3] from F, F^-1, J and the displacement Hessian H [n, i, K, J] (d2 u_i / dX_K dX_J):
  // Div_i P = sum_J dP_iJ(F)[dF = H(:, :, J)], each directional derivative in closed form.
  Tensor divergence(const Tensor& F, const Tensor& Finv, const Tensor& J, const Tensor& H) const {
    const Tensor FinvT = Finv.transpose(1, 2);
    // tr(F^-1 dF_J) = d ln J along X_J; sum_J (F^-1 dF_J F^-1)_Ji = -sum_J d(F^-T)_iJ.
    const Tensor dlnJ = torch::einsum("nab,nbaj->nj", {Finv, H});
    const Tensor inv_term = torch::einsum("nja,nabj->nbj", {Finv, H});
    const Tensor m = torch::einsum("nbj,nbi->ni", {inv_term, Finv});
    const Tensor lap = torch::diagonal(H, 0, 2, 3).sum(2);  // sum_J H[i, J, J]
    const double mu = material->mu();
    const auto col = [](const Tensor& s) { return s.unsqueeze(1); };
    const auto times = [](const Tensor& A, const Tensor& v) { return torch::matmul(A, v.unsqueeze(2)).squeeze(2); };
    if (scenario.material.model == "neo_hookean_decoupled") {
      const double kappa = material->kappa();
      const Tensor I1 = (F * F).sum({1, 2});
      const Tensor c1 = 0.5 * kappa * (J * J - 1), c2 = mu * torch::pow(J, -2.0 / 3.0);
      const Tensor dI1 = 2 * torch::einsum("nab,nabj->nj", {F, H});
      const Tensor dev = F - (I1 / 3).view({-1, 1, 1}) * FinvT;
      return col(kappa * J * J) * times(FinvT, dlnJ) - col(c1) * m - col(2.0 / 3.0 * c2) * times(dev, dlnJ) +
             col(c2) * lap - col(c2 / 3) * times(FinvT, dI1) + col(c2 * I1 / 3) * m;
    }
    const double lambda = material->lambda();
    return mu * lap + lambda * times(FinvT, dlnJ) - col(lambda * torch::log(J) - mu) * m;
  }

  struct Parts {
    Tensor total, residual, traction, displacement;
    double min_J = 1.0;
  };

  // The weighted PINN loss at load fraction `scale`, every term dimensionless (PinnConfig).
  // With `sample`, the equilibrium residual is taken at config.residual_batch random residual
  // particles (fresh every call: stochastic collocation, as PINNs commonly train).
  Parts loss(double scale, bool sample = false) const {
    Parts p;
    const Tensor zero = torch::zeros({}, torch::TensorOptions().dtype(dtype));
    p.residual = p.traction = p.displacement = zero;
    double min_J = std::numeric_limits<double>::infinity();
    if (xr.size(0) > 0) {
      Tensor x = xr, unfixed = free_r, cell = cell_r;
      if (sample && config.residual_batch > 0 && config.residual_batch < xr.size(0)) {
        const Tensor pick = torch::randperm(xr.size(0), torch::kLong).narrow(0, 0, config.residual_batch);
        x = xr.index_select(0, pick);
        unfixed = free_r.index_select(0, pick);
        cell = cell_r.index_select(0, pick);
      }
      if (sample && config.jitter) x = x + (torch::rand_like(x) - 0.5) * cell;
      const NetOut o = network(x, 2);
      const Tensor F = eye3 + o.dz.transpose(1, 2) * out_scale;
      // d2z [n, p, i] -> H [n, i, K, J], symmetric in K, J.
      const Tensor H = o.d2z.index_select(1, hessian_slots).view({-1, 3, 3, 3}).permute({0, 3, 1, 2}) * out_scale;
      Tensor J, Finv;
      std::tie(Finv, J) = inverse3(F);
      min_J = std::min(min_J, J.min().item<double>());
      const Tensor r = (divergence(F, Finv, J, H) + scale * body_r) * (length / stress_scale) * unfixed;
      p.residual = r.pow(2).sum(1).mean();
    }
    if (xs.size(0) > 0) {
      const NetOut o = network(xs, 1);
      const Tensor F = eye3 + o.dz.transpose(1, 2) * out_scale;
      Tensor J, Finv;
      const Tensor P = stress(F, J, Finv);
      min_J = std::min(min_J, J.min().item<double>());
      const Tensor t = ((P * normal_s.unsqueeze(1)).sum(2) - scale * traction_s) / stress_scale * free_s;
      p.traction = t.pow(2).sum(1).mean();
    }
    if (xc.size(0) > 0) {
      const Tensor u = network(xc, 0).z * out_scale;
      // Normalised by the expected displacement, not by out_scale: the amplitude fit sets that to 0.
      const double disp_scale = stress_scale * length / material->mu();
      p.displacement = ((u - scale * fixed_value) / disp_scale * fixed_mask).pow(2).sum(1).mean();
    }
    p.total = config.weight_residual * p.residual + config.weight_traction * p.traction +
              config.weight_displacement * p.displacement;
    p.min_J = min_J;
    return p;
  }

  // Total potential energy of the current field (J): the quantity the DEM minimises, reported so
  // the two methods can be compared on one figure.
  double energy(double scale) const {
    torch::NoGradGuard guard;
    double e = 0.0;
    if (xr.size(0) > 0) {
      const NetOut o = network(xr, 1);
      const Tensor u = o.z * out_scale;
      const Tensor F = eye3 + o.dz.transpose(1, 2) * out_scale;
      Tensor J, Finv;
      std::tie(Finv, J) = inverse3(F);
      const Tensor psi =
          torch_support::neoHookeanEnergyDensity(J, (F * F).sum({1, 2}), *material, scenario.material.model);
      e += ((psi * vol_r).sum() - scale * (body_r * u * vol_r.unsqueeze(1)).sum()).item<double>();
    }
    if (xs.size(0) > 0) {
      const Tensor u = network(xs, 0).z * out_scale;
      e -= scale * (traction_s * u * area_s.unsqueeze(1)).sum().item<double>();
    }
    return e;
  }

  std::vector<Tensor> snapshot() const { return torch_support::snapshot(parameters()); }
  void restore(const std::vector<Tensor>& s) { torch_support::restore(parameters(), s); }

  // Loss with the output amplitude times alpha and the normalisation kept; NaN when inverted.
  double lossWithAmplitude(double scale, double alpha) {
    torch::NoGradGuard guard;
    const double saved = out_scale;
    out_scale = saved * alpha;
    const Parts p = loss(scale);
    out_scale = saved;
    const double v = p.total.item<double>();
    return std::isfinite(v) && p.min_J > 0 ? v : std::numeric_limits<double>::quiet_NaN();
  }

  // The residuals are nearly linear in the amplitude at moderate strain, so the loss is nearly a
  // parabola in it: fit through alpha = 0, 1, 2 (0, 0.5, 1 when 2 inverts) and move to its
  // minimum, clamped to [0.1, 10] per call. The normalisation follows, so the loss stays O(1).
  void refitAmplitude(double scale) {
    const double l0 = lossWithAmplitude(scale, 0.0), l1 = lossWithAmplitude(scale, 1.0);
    double l2 = lossWithAmplitude(scale, 2.0), h = 1.0, la = l0, lb = l1;
    if (!std::isfinite(l2)) {
      h = 0.5;
      lb = lossWithAmplitude(scale, 0.5);
      l2 = l1;
    }
    if (config.verbose) std::cerr << "pinn: amplitude fit losses " << la << " " << lb << " " << l2 << " (h " << h << ")\n";
    if (!std::isfinite(la) || !std::isfinite(lb) || !std::isfinite(l2)) return;
    // Parabola through (0, la), (h, lb), (2h, l2).
    const double c2 = (l2 - 2 * lb + la) / (2 * h * h), c1 = (lb - la) / h - c2 * h;
    double alpha = c2 > 0 ? -c1 / (2 * c2) : 10.0;
    if (!std::isfinite(alpha) || alpha <= 0) return;
    alpha = std::clamp(alpha, 0.1, 10.0);
    out_scale *= alpha;
    stress_scale *= alpha;
    if (config.verbose) std::cerr << "pinn: output amplitude x" << alpha << " -> " << out_scale << " m\n";
  }

  PinnReport solveAll();

  bool admissible(const Parts& p) const { return std::isfinite(p.total.item<double>()) && p.min_J > 0; }

  // Trains at one load fraction; false when the loss turns NaN or a particle inverts.
  bool train(double scale, PinnReport& report) {
    auto params = parameters();
    if (config.adam_iterations > 0) {
      torch::optim::Adam adam(params, torch::optim::AdamOptions(config.adam_learning_rate));
      const int n = config.adam_iterations;
      const double decay = std::pow(std::max(config.adam_final_rate_ratio, 1e-6), 1.0 / std::max(1, n - 1));
      double lr = config.adam_learning_rate;
      for (int it = 0; it < n; ++it) {
        check();
        progress("adam", scale, report.iterations);
        if (!rescaled && config.rescale_every > 0 && it > 0 && it % config.rescale_every == 0 &&
            it <= config.rescale_until)
          refitAmplitude(scale);
        adam.zero_grad();
        const Parts p = loss(scale, true);
        if (!admissible(p)) return false;
        p.total.backward();
        adam.step();
        lr *= decay;
        for (auto& group : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
        ++report.iterations;
        if (config.verbose && (it % 200 == 0 || it + 1 == n))
          std::cerr << "pinn: it " << it << " loss " << p.total.item<double>() << " (R " << p.residual.item<double>()
                    << ", t " << p.traction.item<double>() << ", u " << p.displacement.item<double>() << ")\n";
      }
      rescaled = true;
    }
    if (config.lbfgs_iterations > 0) {
      torch::optim::LBFGS lbfgs(params, torch::optim::LBFGSOptions(1.0)
                                            .max_iter(config.lbfgs_iterations)
                                            .max_eval(config.lbfgs_iterations * 5 / 4)
                                            .history_size(config.lbfgs_history)
                                            .tolerance_grad(1e-12)
                                            .tolerance_change(1e-14)
                                            .line_search_fn("strong_wolfe"));
      auto closure = [&]() -> Tensor {
        check();
        progress("lbfgs", scale, report.iterations);
        lbfgs.zero_grad();
        const Parts p = loss(scale);
        ++report.iterations;
        // An inadmissible trial point must look bad to the line search without entering its history.
        if (!admissible(p)) return torch::full({}, 1e30, torch::TensorOptions().dtype(dtype));
        p.total.backward();
        return p.total;
      };
      lbfgs.step(closure);
      if (config.verbose) {
        torch::NoGradGuard guard;
        std::cerr << "pinn: after L-BFGS loss " << loss(scale).total.item<double>() << "\n";
      }
    }
    torch::NoGradGuard guard;
    for (const Tensor& p : parameters())
      if (!torch::isfinite(p).all().item<bool>()) return false;
    return admissible(loss(scale));
  }
};

PinnSolver::PinnSolver(core::ParticleCloud cloud, const core::Scenario& scenario, PinnConfig config)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  validateProblem(scenario, cloud);
  auto bad = [](const std::string& what, double v) {
    std::ostringstream msg;
    msg << "PINN config: " << what << " = " << v;
    return core::Error(msg.str());
  };
  if (config.width < 1 || config.depth < 1)
    throw core::Error("PINN network needs width >= 1 and depth >= 1, got width " + std::to_string(config.width) +
                      ", depth " + std::to_string(config.depth));
  if (config.activation != "tanh" && config.activation != "sin" && config.activation != "softplus")
    throw core::Error("unknown PINN activation '" + config.activation +
                      "': use tanh, sin or softplus (the residual needs second derivatives)");
  const std::pair<const char*, double> weights[] = {{"weight_residual (W_R)", config.weight_residual},
                                                    {"weight_traction (W_t)", config.weight_traction},
                                                    {"weight_displacement (W_u)", config.weight_displacement}};
  for (const auto& [name, w] : weights)
    if (!std::isfinite(w) || w < 0) throw bad(std::string(name) + " must be finite and >= 0", w);
  if (!(config.weight_residual + config.weight_traction + config.weight_displacement > 0))
    throw core::Error("PINN config: all loss weights are 0, nothing to train");
  if (config.adam_iterations < 0 || config.lbfgs_iterations < 0 || config.adam_iterations + config.lbfgs_iterations == 0)
    throw core::Error("PINN config: adam_iterations and lbfgs_iterations must be >= 0 and not both 0, got " +
                      std::to_string(config.adam_iterations) + " and " + std::to_string(config.lbfgs_iterations));
  if (!std::isfinite(config.adam_learning_rate) || !(config.adam_learning_rate > 0))
    throw bad("adam_learning_rate must be > 0", config.adam_learning_rate);
  if (!std::isfinite(config.adam_final_rate_ratio) || !(config.adam_final_rate_ratio > 0) ||
      config.adam_final_rate_ratio > 1)
    throw bad("adam_final_rate_ratio must be in (0, 1]", config.adam_final_rate_ratio);
  if (config.load_steps < 0) throw bad("load_steps must be >= 0 (0: the scenario's)", config.load_steps);
  if (config.lbfgs_history < 1) throw bad("lbfgs_history must be >= 1", config.lbfgs_history);
  if (!std::isfinite(config.displacement_scale) || config.displacement_scale < 0)
    throw bad("displacement_scale must be finite and >= 0 (0: estimated)", config.displacement_scale);
  if (config.residual_batch < 0) throw bad("residual_batch must be >= 0 (0: all)", config.residual_batch);
  m.config = config;
  m.scenario = scenario;
  m.material = makeMaterial(scenario.material);
  m.dtype = config.double_precision ? torch::kFloat64 : torch::kFloat32;
  m.cloud = std::move(cloud);
  const int threads = config.threads > 0 ? config.threads
                      : m.cloud.size() < 50000 ? 1
                                               : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  at::set_num_threads(threads);
  setBlasThreads(threads);
  keepLargeAllocationsInHeap();
  torch::manual_seed(config.seed);

  Eigen::Vector3d lo = m.cloud.positions[0], hi = lo;
  for (const auto& p : m.cloud.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d half = (0.5 * (hi - lo)).cwiseMax(1e-9 * (hi - lo).norm() + 1e-12);
  m.length = (hi - lo).maxCoeff();
  const auto opts = torch::TensorOptions().dtype(m.dtype);
  m.center_t = toTensor(std::vector<Eigen::Vector3d>{0.5 * (lo + hi)}, m.dtype);
  m.inv_half = toTensor(std::vector<Eigen::Vector3d>{half.cwiseInverse()}, m.dtype).squeeze(0);
  m.eye3 = torch::eye(3, opts).unsqueeze(0);
  m.pair_k = torch::from_blob(const_cast<long*>(kPairK), {6}, torch::kLong).clone();
  m.pair_m = torch::from_blob(const_cast<long*>(kPairM), {6}, torch::kLong).clone();
  m.hessian_slots = torch::from_blob(const_cast<long*>(&kPairOf[0][0]), {9}, torch::kLong).clone();

  // Particle sets. A component prescribed by a fixture at a particle carries a reaction there:
  // neither the equilibrium nor the traction condition holds in that component.
  const auto traction = particleTractions(scenario, m.cloud);
  const Dirichlet fixed = resolveFixtures(scenario, m.cloud.positions);
  std::vector<Eigen::Vector3d> unfixed(m.cloud.size(), Eigen::Vector3d::Ones());
  for (std::size_t k = 0; k < fixed.index.size(); ++k)
    unfixed[fixed.index[k]] = Eigen::Vector3d::Ones() - fixed.mask[k].cast<double>();
  std::vector<Eigen::Vector3d> xr, fr, xs, ns, ts, fs, body;
  std::vector<double> vr, as;
  double max_t = 0.0;
  for (std::size_t i = 0; i < m.cloud.size(); ++i) {
    if (m.cloud.volumes[i] > 0 && !unfixed[i].isZero()) {
      xr.push_back(m.cloud.positions[i]);
      fr.push_back(unfixed[i]);
      vr.push_back(m.cloud.volumes[i]);
    }
    if (m.cloud.isSurface(i) && !unfixed[i].isZero()) {
      xs.push_back(m.cloud.positions[i]);
      ns.push_back(m.cloud.normals[i].normalized());
      ts.push_back(traction[i]);
      fs.push_back(unfixed[i]);
      as.push_back(m.cloud.areas[i]);
    }
    max_t = std::max(max_t, traction[i].norm());
  }
  if (xr.empty()) throw core::Error("PINN: no particle with volume > 0 outside the fixtures carries the equilibrium residual");
  const auto scalars = [&](const std::vector<double>& v) {
    return torch::from_blob(const_cast<double*>(v.data()), {static_cast<long>(v.size())}, torch::kFloat64).clone().to(m.dtype);
  };
  m.xr = toTensor(xr, m.dtype);
  m.free_r = toTensor(fr, m.dtype);
  m.vol_r = scalars(vr);
  m.cell_r = torch::pow(m.vol_r, 1.0 / 3.0).unsqueeze(1);
  m.body_r = toTensor(std::vector<Eigen::Vector3d>{scenario.body_force}, m.dtype);
  m.xs = toTensor(xs, m.dtype);
  m.normal_s = toTensor(ns, m.dtype);
  m.traction_s = toTensor(ts, m.dtype);
  m.free_s = toTensor(fs, m.dtype);
  m.area_s = scalars(as);
  std::vector<Eigen::Vector3d> xc, mask;
  double max_g = 0.0;
  for (std::size_t k = 0; k < fixed.index.size(); ++k) {
    xc.push_back(m.cloud.positions[fixed.index[k]]);
    mask.push_back(fixed.mask[k].cast<double>());
    max_g = std::max(max_g, fixed.value[k].norm());
  }
  m.xc = toTensor(xc, m.dtype);
  m.fixed_value = toTensor(fixed.value, m.dtype);
  m.fixed_mask = toTensor(mask, m.dtype);
  // A-priori displacement scale, as the DEM's; refitted by refitAmplitude during the first steps.
  m.out_scale = std::max({max_g, m.length * (max_t + scenario.body_force.norm() * m.length) /
                                     scenario.material.youngs_modulus,
                          1e-6 * m.length});
  if (config.displacement_scale > 0) m.out_scale = config.displacement_scale;
  m.stress_scale = m.material->mu() * m.out_scale / m.length;

  int in = 3;
  for (int l = 0; l <= config.depth; ++l) {
    const int out = l == config.depth ? 3 : config.width;
    const double bound = std::sqrt(6.0 / (in + out));
    Tensor W = (torch::rand({out, in}, opts) * 2 - 1) * bound;
    // The output layer starts at zero: training begins from the rest state u = 0.
    if (l == config.depth) W.zero_();
    m.weights.push_back(W.requires_grad_(true));
    m.biases.push_back(torch::zeros({out}, opts).requires_grad_(true));
    in = out;
  }
}

PinnReport PinnSolver::solve() {
  impl_->clock = nullptr;
  return impl_->solveAll();
}

PinnReport PinnSolver::solve(const SolveControl& control) {
  SolveClock clock(control, "pinn");
  return solve(clock);
}

PinnReport PinnSolver::solve(SolveClock& clock) {
  impl_->clock = &clock;
  impl_->last_report = -1e300;
  struct Detach {  // the clock lives only as long as this call
    Impl& m;
    ~Detach() { m.clock = nullptr; }
  } detach{*impl_};
  return impl_->solveAll();
}

PinnReport PinnSolver::Impl::solveAll() {
  Impl& m = *this;
  const auto start = std::chrono::steady_clock::now();
  PinnReport report;
  std::vector<Tensor> saved;
  double saved_out = 0.0, saved_stress = 0.0;
  auto undo = [&](double) {
    m.restore(saved);
    m.out_scale = saved_out;
    m.stress_scale = saved_stress;
  };
  try {
    report.load_steps = runAdaptiveLoadSteps(
        m.config.load_steps > 0 ? m.config.load_steps : m.scenario.load_steps, m.config.max_halvings,
        [&](double target) {
          saved = m.snapshot();
          saved_out = m.out_scale;
          saved_stress = m.stress_scale;
          if (!m.train(target, report)) return false;
          m.fraction = target;
          return true;
        },
        undo, "PINN", "Use more load_steps, a smaller adam_learning_rate or a smaller load.", m.config.verbose);
  } catch (const SolveError&) {  // out of time or cancelled inside a step: back to the last good one
    if (!saved.empty()) undo(m.fraction);
    throw;
  } catch (const core::Error& e) {  // every halving inverted particles or turned NaN
    throw SolveError(SolveFailure::kInverted, e.what());
  }
  m.fraction = 1.0;
  {
    torch::NoGradGuard guard;
    const Impl::Parts p = m.loss(1.0);
    if (!m.admissible(p))
      throw SolveError(SolveFailure::kInverted, "PINN: the trained field is not admissible (NaN or det F <= 0)");
    report.loss = p.total.item<double>();
    report.residual_mse = p.residual.item<double>();
    report.traction_mse = p.traction.item<double>();
    report.displacement_mse = p.displacement.item<double>();
    report.min_J = p.min_J;
  }
  report.energy = m.energy(1.0);
  report.output_scale = m.out_scale;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

std::vector<Eigen::Vector3d> PinnSolver::predict(const std::vector<Eigen::Vector3d>& points) const {
  const Impl& m = *impl_;
  if (points.empty()) return {};
  torch::NoGradGuard guard;
  return toVectors(m.network(toTensor(points, m.dtype), 0).z * m.out_scale);
}

core::ResultField PinnSolver::result() const {
  const Impl& m = *impl_;
  torch::NoGradGuard guard;
  const Impl::NetOut o = m.network(toTensor(m.cloud.positions, m.dtype), 1);
  core::ResultField r;
  r.positions = m.cloud.positions;
  r.displacements = toVectors(o.z * m.out_scale);
  const Tensor gu = (o.dz.transpose(1, 2) * m.out_scale).to(torch::kFloat64).contiguous();
  const double* g = gu.data_ptr<double>();
  r.von_mises.resize(m.cloud.size());
  for (std::size_t i = 0; i < m.cloud.size(); ++i) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) F(a, b) += g[9 * i + 3 * a + b];
    r.von_mises[i] = F.determinant() > 0 ? vonMises(cauchyStress(F, m.material->stress(F)))
                                         : std::numeric_limits<double>::quiet_NaN();
  }
  return r;
}

double PinnSolver::divergenceSelfCheck() const {
  const Impl& m = *impl_;
  const Tensor x = m.xr.narrow(0, 0, std::min<long>(64, m.xr.size(0))).clone().requires_grad_(true);
  const Impl::NetOut o = m.network(x, 2);
  const Tensor F = m.eye3 + o.dz.transpose(1, 2) * m.out_scale;
  const Tensor H = o.d2z.index_select(1, m.hessian_slots).view({-1, 3, 3, 3}).permute({0, 3, 1, 2}) * m.out_scale;
  Tensor J, Finv;
  const Tensor P = m.stress(F, J, Finv);
  const Tensor forward = m.divergence(F, Finv, J, H).detach();
  Tensor reverse = torch::zeros_like(forward);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      const Tensor g = torch::autograd::grad({P.select(1, i).select(1, k).sum()}, {x}, {}, true)[0];
      reverse.select(1, i) += g.select(1, k).detach();
    }
  const double scale = reverse.abs().max().item<double>();
  return (forward - reverse).abs().max().item<double>() / std::max(scale, 1e-30);
}

PinnSolver::~PinnSolver() = default;
PinnSolver::PinnSolver(PinnSolver&&) noexcept = default;

}  // namespace demnerf::mechanics
