// One DEM load step (output-layer Newton, feature-grid Newton, Adam, L-BFGS polish with its
// exploit guard), parametric training over a load range, and the progress of a running solve.
#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>

#include "dem_solver_impl.hpp"
#include "exploit_guard.hpp"
#include "network_optimisers.hpp"
#include "demnerf/mechanics/output_layer_newton.hpp"

namespace demnerf::mechanics {

using torch::Tensor;

std::string DemSolver::Impl::keptState() const {
  std::ostringstream text;
  text << "the state at load fraction " << done_fraction;
  return text.str();
}

// Progress and the stop checks of a running solve (a no-op outside solve()).
void DemSolver::Impl::tick(const char* phase, double scale, int iterations, double energy, double residual) {
  if (!clock) return;
  SolveProgress p;
  p.phase = phase;
  p.load_fraction = scale;
  p.iteration = iterations;
  p.energy = energy;
  p.residual = residual;
  clock->report(p);
  clock->check(keptState());
}

void DemSolver::Impl::setupTick(const std::string& what, double done) {
  if (!clock) return;
  SolveProgress p;
  std::ostringstream phase;
  phase << "setup: " << what;
  if (std::isfinite(done)) phase << ' ' << std::lround(100 * done) << " %";
  p.phase = phase.str();
  p.residual = std::numeric_limits<double>::quiet_NaN();
  clock->report(p);
  clock->check("nothing: the set-up (" + what + ") took the budget");
}

void DemSolver::Impl::reportProgress(int iterations) const {
  if (progress && progress_every > 0 && iterations % progress_every == 0) progress(iterations);
}

// Why an MLP solve ran out of time: the optimisers' schedule (Adam steps, then L-BFGS iterations
// at about 1.25 evaluations each) at the pace measured in this solve.
std::string DemSolver::Impl::adamPaceAdvice() const {
  std::ostringstream text;
  const int steps = config.parametric.enabled ? 1 : config.load_steps > 0 ? config.load_steps : scenario.load_steps;
  const int lbfgs = config.parametric.enabled ? 0 : config.lbfgs.iterations;
  text << "Likely cause: the MLP's schedule of " << config.adam.iterations << " Adam steps";
  if (lbfgs > 0) text << " and " << lbfgs << " L-BFGS iterations";
  text << " x " << steps << " load step(s)";
  if (adam_steps > 0) {
    const double pace = adam_seconds / adam_steps;
    text << " needs about " << pace * (config.adam.iterations + 1.25 * lbfgs) * steps << " s at the " << 1e3 * pace
         << " ms a step measured here (wall clock) on " << xv.size(0) << " volume particles";
  }
  text << ". Lower adam.iterations, lbfgs.iterations or the load steps, sample fewer particles, raise the limit, or "
          "use the feature-grid DEM (--method grid), which solves by Newton";
  return text.str();
}

bool DemSolver::Impl::newtonEnabled() const {
  return config.output_newton.enabled && config.boundary.kind == DemConfig::Boundary::kExact && !config.parametric.enabled;
}

// Newton on the output layer with the hidden layers frozen (output_layer_newton.hpp): the best
// field in the network's current basis, at the nominal quadrature points. The output scale is
// kept (rescaling the weights to O(1) made Adam's next steps invert particles on the T-bar).
void DemSolver::Impl::solveOutputLayer(double scale) {
  torch::NoGradGuard guard;
  OutputLayerProblem pb;
  basisAt(xv, scale, pb.h, &pb.dh);
  const long n = xv.size(0), m = pb.h.cols();
  pb.g = toEigen(lift_v[0]);
  pb.D = toEigen(lift_v[2]);
  pb.grad_g = toEigen(lift_v[1].reshape({n, 9}));
  pb.grad_D = toEigen(lift_v[3].reshape({n, 9}));
  pb.volume = toEigen(vol.unsqueeze(1)).col(0);
  pb.body = toEigen(body);
  if (xs.size(0) > 0) {
    basisAt(xs, scale, pb.surface_h, nullptr);
    pb.surface_g = toEigen(lift_s[0]);
    pb.surface_D = toEigen(lift_s[2]);
    pb.traction_area = toEigen(traction_area);
  } else {
    pb.surface_h.resize(0, m);
    pb.surface_g.resize(0, 3);
    pb.surface_D.resize(0, 3);
    pb.traction_area.resize(0, 3);
  }
  pb.output_scale = out_scale;
  pb.load_scale = scale;
  Eigen::MatrixXd W(3, m);
  W.leftCols(m - 1) = toEigen(net.weights().back());
  W.col(m - 1) = toEigen(net.biases().back().unsqueeze(1)).col(0);
  OutputLayerNewtonConfig newton;
  newton.max_iterations = config.output_newton.iterations;
  const OutputLayerNewtonOutcome outcome = minimiseOutputLayer(pb, *material, W, newton);
  const Tensor w = torch::from_blob(W.data(), {m, 3}, torch::kFloat64).t().to(dtype);  // column-major W
  net.weights().back().copy_(w.narrow(1, 0, m - 1));
  net.biases().back().copy_(w.select(1, m - 1));
  if (config.verbose)
    std::cerr << "dem: output-layer Newton " << outcome.iterations << " its, energy " << outcome.energy
              << (outcome.converged ? "" : " (not converged)") << ", output scale " << out_scale << " m\n";
}

// Parametric mode: one Adam run over the whole load range. Each step draws
// parametric.samples load fractions (stratified over the range) and minimises the sum of their
// potential energies, each divided by its own scale (energy grows with the load squared), so
// small and large loads are learnt alike. False when a sample inverts particles or turns NaN.
bool DemSolver::Impl::trainParametric(int& iterations) {
  const double lo = config.parametric.load_range_min, hi = config.parametric.load_range_max;
  const double floor = 0.05 * load_input_scale;  // keeps samples near 0 from dominating
  const int k = std::max(1, config.parametric.samples);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  fraction = 1.0;  // what predict() shows from a progress callback
  const int n = std::max(1, config.adam.iterations);
  DecayingAdam adam(parameters(), config.adam.learning_rate, config.adam.final_rate_ratio, n);
  for (int it = 0; it < n; ++it) {
    adam.zeroGrad();
    Tensor total;
    for (int j = 0; j < k; ++j) {
      const double s = lo + (hi - lo) * (j + u01(rng)) / k;
      double jmin = 0;
      Tensor l = loss(s, nullptr, &jmin, config.adam.jitter) / (s * s + floor * floor);
      if (!std::isfinite(l.item<double>()) || !(jmin > 0)) return false;
      if (j == 0) tick("adam", s, iterations, l.item<double>() * energy_scale * (s * s + floor * floor),
                       std::numeric_limits<double>::quiet_NaN());
      total = j == 0 ? l : total + l;
    }
    (total / k).backward();
    adam.step();
    reportProgress(++iterations);
  }
  // The trained field must be admissible over the whole range, not only at the samples drawn.
  torch::NoGradGuard guard;
  for (int j = 0; j <= 8; ++j) {
    double jmin = 0;
    const Tensor l = loss(lo + (hi - lo) * j / 8.0, nullptr, &jmin);
    if (!std::isfinite(l.item<double>()) || !(jmin > 0)) return false;
  }
  return true;
}

// Trains at one load fraction; false when the loss turns NaN or a particle inverts.
bool DemSolver::Impl::train(double scale, int& iterations, DemReport& report) {
  fraction = scale;  // what predict() shows from a progress callback
  const bool newton = newtonEnabled();
  if (newton) solveOutputLayer(scale);
  if (grid && !solveGrid(scale, iterations)) return false;
  if (config.adam.iterations > 0) {
    if (!runAdam(scale, iterations)) return false;
    rescaled = true;
  }
  if (newton) solveOutputLayer(scale);
  if (grid && config.adam.iterations > 0 && !solveGrid(scale, iterations)) return false;
  if (config.lbfgs.iterations > 0) {
    if (config.lbfgs.sample_iterations > 0 && ((config.adam.jitter && n_band > 0) || config.lbfgs.cell_spacings > 0))
      trainWithSampledLbfgs(scale, iterations);
    else polishWithLbfgs(scale, iterations, report);
  }
  if (config.gauss_newton.steps > 0) gaussNewton(scale, iterations, config.gauss_newton.tolerance);
  torch::NoGradGuard guard;
  double jmin = 0;
  const Tensor l = loss(scale, nullptr, &jmin);
  for (const Tensor& p : parameters())
    if (!torch::isfinite(p).all().item<bool>()) return false;
  return std::isfinite(l.item<double>()) && jmin > 0;
}

// Adam over the particles (jittered near fixtures), with the amplitude refits of the first load
// step and the periodic output-layer Newton; false when the loss turns NaN or a particle inverts.
bool DemSolver::Impl::runAdam(double scale, int& iterations) {
  const bool newton = newtonEnabled();
  const int n = config.adam.iterations;
  DecayingAdam adam(parameters(), config.adam.learning_rate, config.adam.final_rate_ratio, n);
  auto last = std::chrono::steady_clock::now();
  for (int it = 0; it < n; ++it) {
    const auto now = std::chrono::steady_clock::now();
    adam_seconds += std::chrono::duration<double>(now - last).count();
    adam_steps += it > 0;
    last = now;
    if (!newton && !grid && !rescaled && config.adam.rescale_every > 0 && it > 0 && it % config.adam.rescale_every == 0 &&
        it <= config.adam.rescale_until && config.boundary.kind == DemConfig::Boundary::kExact)
      rescaleOutput(scale);
    adam.zeroGrad();
    double jmin = 0;
    Tensor l = loss(scale, nullptr, &jmin, config.adam.jitter);
    const double value = l.item<double>();
    if (!std::isfinite(value) || !(jmin > 0)) return false;
    tick("adam", scale, iterations, value * energy_scale, std::numeric_limits<double>::quiet_NaN());
    l.backward();
    adam.step();
    reportProgress(++iterations);
    if (newton && config.output_newton.every > 0 && (it + 1) % config.output_newton.every == 0 && it + 1 < n)
      solveOutputLayer(scale);
  }
  return true;
}

// L-BFGS on the fixed particles, undone (report.polish_rejected) when it lowers the energy or
// grows the displacement far more than a legitimate polish does: the ramp exploit
// (DemConfig::polish_max_energy_drop).
void DemSolver::Impl::polishWithLbfgs(double scale, int& iterations, DemReport& report) {
  const auto before = snapshot();
  double e_before = 0;
  {
    torch::NoGradGuard guard;
    loss(scale, &e_before, nullptr);
  }
  const double u_before = maxDisplacement(scale);
  runLbfgs(parameters(), config.lbfgs.iterations, config.lbfgs.history, config.lbfgs.tolerance, [&] {
    double jm = 0;
    Tensor l = loss(scale, nullptr, &jm);
    reportProgress(++iterations);
    tick("lbfgs", scale, iterations, l.item<double>() * energy_scale, std::numeric_limits<double>::quiet_NaN());
    return std::make_pair(l, std::isfinite(l.item<double>()) && jm > 0);
  });
  double e_after = 0, jm = 0;
  {
    torch::NoGradGuard guard;
    loss(scale, &e_after, &jm);
  }
  const double u_after = maxDisplacement(scale);
  const bool exploit = !std::isfinite(e_after) || !(jm > 0) ||
                       e_after < e_before - config.lbfgs.max_energy_drop * std::abs(e_before) ||
                       u_after > config.lbfgs.max_growth * u_before || u_after > length;
  if (exploit) {
    if (config.verbose)
      std::cerr << "dem: L-BFGS polish rejected (energy " << e_before << " -> " << e_after << ", max |u| " << u_before
                << " -> " << u_after << ")\n";
    restore(before);
    report.polish_rejected = true;
  } else if (config.verbose) {
    std::cerr << "dem: L-BFGS polish energy " << e_before << " -> " << e_after << "\n";
  }
}

// L-BFGS as the training (DemConfig::lbfgs.sample_iterations): on one jitter draw at a time, a
// fresh one every sample_iterations iterations, so that no draw is minimised long enough for the
// network to exploit the gaps between its points (a fixed quadrature is: on Beam3D's grid
// particles L-BFGS took the energy to 7x the FEM's within 600 evaluations). No exploit guard: the
// equilibrium check after the solve judges the answer.
void DemSolver::Impl::trainWithSampledLbfgs(double scale, int& iterations) {
  JitterDraw draw;
  const bool fused = fusedLossAvailable();  // the loss sets the gradient itself (no graph)
  auto last = std::chrono::steady_clock::now();
  const int per_draw = std::max(1, config.lbfgs.sample_iterations);
  int done = 0;
  // The first draws one at a time, each followed by balanceOutput(), while the amplitude is off by
  // more than 2x; then the rest in one run (one L-BFGS history across its draws).
  for (int balance = 0; balance < kBalanceDraws && done + per_draw < config.lbfgs.iterations; ++balance) {
    sampledLbfgsRun(scale, iterations, per_draw, fused, draw, last);
    done += per_draw;
    if (!balanceOutput(scale)) break;
  }
  sampledLbfgsRun(scale, iterations, config.lbfgs.iterations - done, fused, draw, last);
}

// Output balance: the network's output z is kept O(1) (largest |z| over the particles between
// 1/2 and 2) by moving its amplitude into out_scale, a reparametrisation that leaves u unchanged.
// The a-priori scale (traction x length / E) is 60-140x below the answer on Beam3D and the T-bar
// twist, and the output layer's weights growing to that size make the hidden layers' curvature
// ~1e4 times the output layer's, which L-BFGS's scalar initial Hessian does not bridge. True when
// it rescaled (the L-BFGS history, for the old parameters, must restart).
bool DemSolver::Impl::balanceOutput(double scale) {
  torch::NoGradGuard guard;
  const double zmax = net.forward(xv, loadInput(xv, scale), 0).value.abs().max().item<double>();
  if (!(zmax > 0) || !std::isfinite(zmax) || (zmax > 0.5 && zmax < 2.0)) return false;
  net.weights().back().div_(zmax);
  net.biases().back().div_(zmax);
  out_scale *= zmax;
  energy_scale *= zmax * zmax;
  if (config.verbose) std::cerr << "dem: output balanced x" << zmax << " -> " << out_scale << " m\n";
  return true;
}

// `count` L-BFGS iterations on jitter draws, a fresh history (trainWithSampledLbfgs).
void DemSolver::Impl::sampledLbfgsRun(double scale, int& iterations, int count, bool fused, JitterDraw& draw,
                                      std::chrono::steady_clock::time_point& last) {
  if (count <= 0) return;
  // The cell quadrature is one fixed draw: a single run, one history.
  const bool cells = config.lbfgs.cell_spacings > 0;
  // Exploit guard (fixed cell points, fused kernel; exploit_guard.hpp): every 20 evaluations.
  const bool guard = cells && fused;
  ExploitGuard watchman(20, "evaluations");
  exploit_kept.clear();
  const auto watch = [&] {
    if (!guard || !watchman.due()) return;
    torch::NoGradGuard no_grad;
    watchman.record(shiftedCellEnergy(scale), displacement(xv, lift_v, false, scale).first, [&] { return snapshot(); });
  };
  runSampledLbfgs(
      parameters(), count, cells ? count : config.lbfgs.sample_iterations, config.lbfgs.history,
      config.lbfgs.tolerance,
      [&] {
        double jm = 0;
        Tensor l = fused ? fusedLoss(scale, draw, true, nullptr, &jm) : loss(scale, nullptr, &jm, true, &draw);
        watch();
        const double value = l.item<double>();
        const auto now = std::chrono::steady_clock::now();
        adam_seconds += std::chrono::duration<double>(now - last).count();  // the pace the time-limit advice quotes
        adam_steps += 1;
        last = now;
        reportProgress(++iterations);
        tick("lbfgs", scale, iterations, value * energy_scale, std::numeric_limits<double>::quiet_NaN());
        return std::make_pair(l, std::isfinite(value) && jm > 0);
      },
      [&] { draw = cells ? cellDraw() : drawJitter(); });
  if (guard) keepGuardedBest(watchman, scale);
}

// The fused energy on the shifted cell points; inf where the field inverts there.
double DemSolver::Impl::shiftedCellEnergy(double scale) {
  torch::NoGradGuard no_grad;
  double energy = 0.0, jm = 0.0;
  fusedLoss(scale, shiftedCellDraw(), false, &energy, &jm);
  return std::isfinite(energy) && jm > 0 ? energy : std::numeric_limits<double>::infinity();
}

// At the end of a guarded training: back to the guard's best sample when the final state's
// shifted energy is clearly worse; that state is refused later (exploit_kept) unless it had settled.
void DemSolver::Impl::keepGuardedBest(ExploitGuard& guard, double scale) {
  const double final_energy = shiftedCellEnergy(scale);
  if (!guard.keepBest(final_energy, exploit_kept)) return;
  if (config.verbose)
    std::cerr << "dem: exploit guard: shifted points' energy " << final_energy << " J, best " << guard.bestEnergy()
              << " J after " << guard.bestEvaluation() << " " << guard.unit() << "; keeping the best"
              << (exploit_kept.empty() ? " (settled)" : " (still moving: refused)") << "\n";
  restore(guard.best());
}

}  // namespace demnerf::mechanics
