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
#include "attached_clock.hpp"
#include "amplitude_fit.hpp"
#include "network_optimisers.hpp"
#include "displacement_mlp.hpp"
#include "pinn_config_check.hpp"
#include "pinn_point_sets.hpp"
#include "pinn_strong_form.hpp"
#include "torch_solver_support.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;
using torch_support::toTensor;
using torch_support::toVectors;

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
  DisplacementMlp net;
  Tensor eye3, hessian_slots;
  // Residual particles (volume > 0) with the mask of the components not prescribed there;
  // traction particles (area > 0) with normal, full-load traction and free mask; fixed particles.
  Tensor xr, free_r, xs, normal_s, traction_s, free_s, xc, fixed_value, fixed_mask;
  // Quadrature weights of the reported energy; cell_r: the edge of each residual particle's cell [n, 1].
  Tensor vol_r, body_r, area_s, cell_r;
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

  std::vector<Tensor> parameters() const { return net.parameters(); }

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
      const DisplacementMlp::Output o = net.forward(x, 2);
      const Tensor F = eye3 + o.d1.transpose(1, 2) * out_scale;
      // d2z [n, p, i] -> H [n, i, K, J], symmetric in K, J.
      const Tensor H = o.d2.index_select(1, hessian_slots).view({-1, 3, 3, 3}).permute({0, 3, 1, 2}) * out_scale;
      Tensor J, Finv;
      std::tie(Finv, J) = pinn_strong_form::inverse3(F);
      min_J = std::min(min_J, J.min().item<double>());
      const Tensor r = (pinn_strong_form::stressDivergence(F, Finv, J, H, *material, scenario.material.model) + scale * body_r) * (length / stress_scale) * unfixed;
      p.residual = r.pow(2).sum(1).mean();
    }
    if (xs.size(0) > 0) {
      const DisplacementMlp::Output o = net.forward(xs, 1);
      const Tensor F = eye3 + o.d1.transpose(1, 2) * out_scale;
      Tensor J, Finv;
      const Tensor P = pinn_strong_form::firstPiolaStress(F, J, Finv, *material, scenario.material.model);
      min_J = std::min(min_J, J.min().item<double>());
      const Tensor t = ((P * normal_s.unsqueeze(1)).sum(2) - scale * traction_s) / stress_scale * free_s;
      p.traction = t.pow(2).sum(1).mean();
    }
    if (xc.size(0) > 0) {
      const Tensor u = net.forward(xc, 0).value * out_scale;
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
      const DisplacementMlp::Output o = net.forward(xr, 1);
      const Tensor u = o.value * out_scale;
      const Tensor F = eye3 + o.d1.transpose(1, 2) * out_scale;
      Tensor J, Finv;
      std::tie(Finv, J) = pinn_strong_form::inverse3(F);
      const Tensor psi =
          torch_support::neoHookeanEnergyDensity(J, (F * F).sum({1, 2}), *material, scenario.material.model);
      e += ((psi * vol_r).sum() - scale * (body_r * u * vol_r.unsqueeze(1)).sum()).item<double>();
    }
    if (xs.size(0) > 0) {
      const Tensor u = net.forward(xs, 0).value * out_scale;
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
  // parabola in it (amplitude_fit.hpp). The normalisation follows, so the loss stays O(1).
  void refitAmplitude(double scale) {
    const std::optional<double> alpha = fitAmplitude([&](double a) { return lossWithAmplitude(scale, a); });
    if (!alpha) return;
    out_scale *= *alpha;
    stress_scale *= *alpha;
    if (config.verbose) std::cerr << "pinn: output amplitude x" << *alpha << " -> " << out_scale << " m\n";
  }

  PinnReport solveAll();

  bool admissible(const Parts& p) const { return std::isfinite(p.total.item<double>()) && p.min_J > 0; }

  // Trains at one load fraction; false when the loss turns NaN or a particle inverts.
  bool train(double scale, PinnReport& report) {
    auto params = parameters();
    if (config.adam_iterations > 0) {
      const int n = config.adam_iterations;
      DecayingAdam adam(params, config.adam_learning_rate, config.adam_final_rate_ratio, n);
      for (int it = 0; it < n; ++it) {
        check();
        progress("adam", scale, report.iterations);
        if (!rescaled && config.rescale_every > 0 && it > 0 && it % config.rescale_every == 0 &&
            it <= config.rescale_until)
          refitAmplitude(scale);
        adam.zeroGrad();
        const Parts p = loss(scale, true);
        if (!admissible(p)) return false;
        p.total.backward();
        adam.step();
        ++report.iterations;
        if (config.verbose && (it % 200 == 0 || it + 1 == n))
          std::cerr << "pinn: it " << it << " loss " << p.total.item<double>() << " (R " << p.residual.item<double>()
                    << ", t " << p.traction.item<double>() << ", u " << p.displacement.item<double>() << ")\n";
      }
      rescaled = true;
    }
    if (config.lbfgs_iterations > 0) {
      runLbfgs(params, config.lbfgs_iterations, config.lbfgs_history, 1e-14, [&] {
        check();
        progress("lbfgs", scale, report.iterations);
        const Parts p = loss(scale);
        ++report.iterations;
        return std::make_pair(p.total, admissible(p));
      });
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
  checkPinnConfig(config);
  m.config = config;
  m.scenario = scenario;
  m.material = makeMaterial(scenario.material);
  m.dtype = config.double_precision ? torch::kFloat64 : torch::kFloat32;
  m.cloud = std::move(cloud);
  torch::manual_seed(config.seed);

  const torch_support::BodyBox box = torch_support::bodyBox(m.cloud);
  m.length = box.length;
  const auto opts = torch::TensorOptions().dtype(m.dtype);
  m.eye3 = torch::eye(3, opts).unsqueeze(0);
  m.hessian_slots =
      torch::from_blob(const_cast<long*>(DisplacementMlp::kSlotOf), {9}, torch::kLong).clone();
  m.net = DisplacementMlp(0, config.width, config.depth, config.activation, box.center, box.half, m.dtype);

  const PinnPointSets sets = pinnPointSets(scenario, m.cloud);
  m.xr = toTensor(sets.residual_points, m.dtype);
  m.free_r = toTensor(sets.residual_free, m.dtype);
  m.vol_r = toTensor(sets.residual_volume, m.dtype);
  m.cell_r = torch::pow(m.vol_r, 1.0 / 3.0).unsqueeze(1);
  m.body_r = toTensor(std::vector<Eigen::Vector3d>{scenario.body_force}, m.dtype);
  m.xs = toTensor(sets.surface_points, m.dtype);
  m.normal_s = toTensor(sets.surface_normal, m.dtype);
  m.traction_s = toTensor(sets.surface_traction, m.dtype);
  m.free_s = toTensor(sets.surface_free, m.dtype);
  m.area_s = toTensor(sets.surface_area, m.dtype);
  m.xc = toTensor(sets.fixed_points, m.dtype);
  m.fixed_value = toTensor(sets.fixed_value, m.dtype);
  m.fixed_mask = toTensor(sets.fixed_mask, m.dtype);
  // A-priori displacement scale, as the DEM's; refitted by refitAmplitude during the first steps.
  m.out_scale = std::max({sets.max_prescribed,
                          m.length * (sets.max_traction + scenario.body_force.norm() * m.length) /
                              scenario.material.youngs_modulus,
                          1e-6 * m.length});
  if (config.displacement_scale > 0) m.out_scale = config.displacement_scale;
  m.stress_scale = m.material->mu() * m.out_scale / m.length;
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
  impl_->last_report = -1e300;
  const AttachedClock attached(impl_->clock, clock);
  return impl_->solveAll();
}

PinnReport PinnSolver::Impl::solveAll() {
  Impl& m = *this;
  torch_support::setSolverThreads(m.config.threads, m.cloud.size());
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
  return toVectors(m.net.forward(toTensor(points, m.dtype), 0).value * m.out_scale);
}

core::ResultField PinnSolver::result() const {
  const Impl& m = *impl_;
  torch::NoGradGuard guard;
  const DisplacementMlp::Output o = m.net.forward(toTensor(m.cloud.positions, m.dtype), 1);
  core::ResultField r;
  r.positions = m.cloud.positions;
  r.displacements = toVectors(o.value * m.out_scale);
  r.von_mises = torch_support::vonMisesFromGradients(o.d1.transpose(1, 2) * m.out_scale, *m.material);
  return r;
}

double PinnSolver::divergenceSelfCheck() const {
  const Impl& m = *impl_;
  const Tensor x = m.xr.narrow(0, 0, std::min<long>(64, m.xr.size(0))).clone().requires_grad_(true);
  const DisplacementMlp::Output o = m.net.forward(x, 2);
  const Tensor F = m.eye3 + o.d1.transpose(1, 2) * m.out_scale;
  const Tensor H = o.d2.index_select(1, m.hessian_slots).view({-1, 3, 3, 3}).permute({0, 3, 1, 2}) * m.out_scale;
  Tensor J, Finv;
  const Tensor P = pinn_strong_form::firstPiolaStress(F, J, Finv, *m.material, m.scenario.material.model);
  const Tensor forward =
      pinn_strong_form::stressDivergence(F, Finv, J, H, *m.material, m.scenario.material.model).detach();
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
