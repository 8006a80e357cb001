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
#include <dlfcn.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "dem_solver_impl.hpp"
#include "exploit_guard.hpp"
#include "mlp_energy_kernel.hpp"
#include "strain_jacobian.hpp"

namespace demnerf::mechanics {

using torch::Tensor;

namespace {

// Past this damping (relative to G's mean diagonal) the step is a tiny gradient step: stop.
constexpr double kMaxDamping = 1e8;

// The metric's rows A at the drawn points x (their weights w, the lift's four fields there), [rows,
// parameters] float: by hand (strain_jacobian.hpp), each point forward once and backward once per
// row, on `threads` (0: every core). The autograd rows cost 0.46 s a step on the NeRF T-bar, as
// much as the rest of the step.
Tensor strainRows(const mlp_kernel::Network& nn, const Tensor& x, const Tensor (&lift)[4], const Tensor& w,
                  const strain_rows::Metric& metric, int threads) {
  const auto floats = [](const Tensor& t) { return t.to(torch::kFloat32).contiguous(); };
  const Tensor xs = floats(x), ws = floats(w), g = floats(lift[0]), gg = floats(lift[1]), D = floats(lift[2]),
               gD = floats(lift[3]);
  mlp_kernel::VolumePoints points{xs.size(0), xs.data_ptr<float>(), ws.data_ptr<float>(), nullptr,
                                  g.data_ptr<float>(), gg.data_ptr<float>(), D.data_ptr<float>(), gD.data_ptr<float>()};
  Tensor rows = torch::empty({xs.size(0) * strain_rows::rowsPerPoint(metric), strain_rows::parameterCount(nn)},
                             torch::kFloat32);
  strain_rows::strainJacobianRows(nn, metric, points, rows.data_ptr<float>(),
                                  threads > 0 ? threads : torch_support::allCores());
  return rows;
}

// G = A^T A in double from float rows, by BLAS's ssyrk when the process has one (one triangle:
// half sgemm's products, the same G to the bit here; 0.26 -> 0.15 s a step on the NeRF T-bar's
// 3,000 x 2,073 rows beside another busy process), mirrored.
Tensor gramian(const Tensor& A) {
  using Syrk = void (*)(const char*, const char*, const int*, const int*, const float*, const float*, const int*,
                        const float*, float*, const int*);
  static const auto syrk = reinterpret_cast<Syrk>(dlsym(RTLD_DEFAULT, "ssyrk_"));
  if (!syrk) return torch::mm(A.t(), A).to(torch::kFloat64);
  // Row-major A [k, n] is column-major A^T [n, k]: C = A^T (A^T)^T, its column-major lower triangle
  // the row-major upper one.
  const int n = static_cast<int>(A.size(1)), k = static_cast<int>(A.size(0));
  const float one = 1.0f, zero = 0.0f;
  Tensor C = torch::zeros({n, n}, torch::kFloat32);
  syrk("L", "N", &n, &k, &one, A.contiguous().data_ptr<float>(), &n, &zero, C.data_ptr<float>(), &n);
  const Tensor upper = C.to(torch::kFloat64);
  return upper + upper.triu(1).t();
}

// BLAS on every core while the steps run, torch on one, unless the user pinned a count: a step's
// dense work is ssyrk and the damped Cholesky (OpenBLAS's own threads), its energies the fused
// kernel's and its metric rows strain_jacobian's (std::threads of their own). Torch's remaining
// operations are a few copies of G. With torch on two threads its OpenMP workers spun between
// them, and OpenBLAS's after every call (parkBlasThreads): 40 steps on the NeRF T-bar took 15 s
// wall on the quiet machine against 11.5 s with both kinds of worker made to sleep, and 32 s
// beside another busy process against 20 s with this and parkBlasThreads. Restored after.
class DenseAlgebraThreads {
 public:
  explicit DenseAlgebraThreads(int pinned) : before_(at::get_num_threads()) {
    if (pinned == 0) {
      at::set_num_threads(1);
      setBlasThreads(torch_support::allCores());
    }
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

// Where the steps' time goes, for dem.verbose: wall and process CPU seconds (all threads, spinning
// ones too) per phase, each lap charged to the phase that just ended.
class StepPhases {
 public:
  enum Phase { kGuard, kGradient, kRows, kGram, kSolve, kTrials, kCount };
  void lap(Phase p) {
    const auto now = Clock::now();
    const std::clock_t cpu = std::clock();
    wall_[p] += std::chrono::duration<double>(now - wall_at_).count();
    cpu_[p] += static_cast<double>(cpu - cpu_at_) / CLOCKS_PER_SEC;
    wall_at_ = now;
    cpu_at_ = cpu;
    trials_ += p == kTrials;
  }
  std::string summary(int steps) const {
    static const char* names[kCount] = {"guard", "gradient", "metric rows", "G", "factor+solves", "trial energies"};
    std::ostringstream out;
    out << steps << " steps, " << trials_ << " trials; wall/CPU s:";
    for (int p = 0; p < kCount; ++p) out << (p ? ", " : " ") << names[p] << " " << wall_[p] << "/" << cpu_[p];
    return out.str();
  }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point wall_at_ = Clock::now();
  std::clock_t cpu_at_ = std::clock();
  double wall_[kCount] = {}, cpu_[kCount] = {};
  int trials_ = 0;
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
  strain_rows::Metric metric;
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
  StepPhases phases;
  while (!stop.done(damping < kMaxDamping, clock ? clock->elapsed() : 0.0)) {
    balanceOutput(scale);  // a no-op once balanced; GN alone starts at the a-priori amplitude
    if (watchman.due()) {
      torch::NoGradGuard no_grad;
      watchman.record(shiftedCellEnergy(scale), displacement(xv, lift_v, false, scale).first, [&] { return snapshot(); });
    }
    phases.lap(StepPhases::kGuard);
    metric.output_scale = out_scale;
    metric.energy_scale = energy_scale;
    double energy = 0.0, jm = 0.0;
    const double e0 = fusedLoss(scale, draw, true, &energy, &jm).item<double>(), start_energy = energy;
    if (!std::isfinite(e0)) return;
    const Tensor grad = flatten(net, true), theta = flatten(net, false);
    phases.lap(StepPhases::kGradient);
    const auto [idx, w] = metric_draw.next(rng);
    const Tensor lift[4] = {draw.lift[0].index_select(0, idx), draw.lift[1].index_select(0, idx),
                            draw.lift[2].index_select(0, idx), draw.lift[3].index_select(0, idx)};
    const Tensor A = strainRows(kernelNetwork(), draw.x.index_select(0, idx), lift, w, metric, config.threads);
    phases.lap(StepPhases::kRows);
    const Tensor G = gramian(A);
    phases.lap(StepPhases::kGram);
    // Until the energy falls, or the damping says the model is not to be trusted.
    const double accepted = dampedStep(G, grad, damping, [&](const Tensor& d, double predicted) {
      assign(net, theta + d);
      parkBlasThreads();  // the energies run on the kernel's threads: no BLAS worker spinning beside them
      phases.lap(StepPhases::kSolve);
      const double e1 = fusedLoss(scale, draw, false, &energy, &jm).item<double>();
      phases.lap(StepPhases::kTrials);
      const double rho = (e0 - e1) / predicted;
      if (std::isfinite(e1) && rho > 0) return rho;
      assign(net, theta);
      return 0.0;
    }) ? energy : start_energy;
    phases.lap(StepPhases::kSolve);
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
  if (config.verbose)
    std::cerr << "dem: " << gauss_newton_ended << "\ndem: Gauss-Newton time: " << phases.summary(stop.steps()) << "\n";
  keepGuardedBest(watchman, scale);
}

}  // namespace demnerf::mechanics
