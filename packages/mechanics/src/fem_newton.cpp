// The FEM's solve: a direct factor (fem_factor.hpp; reused while it still converges) or conjugate
// gradients, Newton with a backtracking line search, and load steps halved on failure.
#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "attached_clock.hpp"
#include "fem_solver_impl.hpp"

namespace demnerf::mechanics {
namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// Backtracking on the potential energy along a Newton step: the first of 12 halvings whose
/// energy is finite (a step that inverts an element has infinite energy) and, when the
/// constrained dofs are at their targets, decreases enough. Near convergence energy differences
/// drown in round-off, so a relative slack is allowed.
struct LineSearch {
  bool accepted = false, any_finite = false;
  double alpha = 1.0;
};

template <class EnergyAt>
LineSearch backtrack(const EnergyAt& energy_at, double e0, double slope, bool require_decrease) {
  LineSearch out;
  for (int k = 0; k < 12; ++k, out.alpha *= 0.5) {
    const double e = energy_at(out.alpha);
    if (!std::isfinite(e)) continue;
    out.any_finite = true;
    if (!require_decrease || e <= e0 + 1e-4 * out.alpha * slope + 1e-12 * std::abs(e0)) {
      out.accepted = true;
      return out;
    }
  }
  return out;
}

void reportNewton(SolveClock& clock, double scale, int iteration, double energy, double residual) {
  SolveProgress progress;
  progress.phase = "newton";
  progress.load_fraction = scale;
  progress.iteration = iteration;
  progress.energy = energy;
  progress.residual = residual;
  clock.report(progress);
}

}  // namespace

Eigen::VectorXd FemSolver::Impl::solveLinear(const Eigen::VectorXd& rhs, double eta) {
  if (config.linear_solver == FemConfig::LinearSolver::kConjugateGradient) {
    Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower, Eigen::IncompleteCholesky<double>> cg;
    cg.setTolerance(config.cg_tolerance);
    cg.setMaxIterations(10 * n_free);
    cg.compute(K);
    Eigen::VectorXd x = cg.solve(rhs);
    if (cg.info() != Eigen::Success) throw core::Error("FEM: conjugate gradients did not converge");
    result.cg_iterations += static_cast<int>(cg.iterations());
    return x;
  }
  auto t0 = std::chrono::steady_clock::now();
  if (factor_valid && config.reuse_factorisation_iterations > 0) {
    // Newton tangents change little between iterations and load steps: the last factorisation
    // is an excellent preconditioner, and a few triangular solves cost far less than a new one.
    const auto Ks = K.selfadjointView<Eigen::Lower>();
    const double target = eta * rhs.norm();
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n_free), r = rhs, z = factorSolve(r), p = z, Ap(n_free);
    double rz = r.dot(z);
    for (int it = 1; it <= config.reuse_factorisation_iterations; ++it) {
      Ap.noalias() = Ks * p;
      const double pAp = p.dot(Ap);
      if (!(pAp > 0.0)) break;  // not positive definite along p: refactorise
      const double alpha = rz / pAp;
      x += alpha * p;
      r -= alpha * Ap;
      ++result.cg_iterations;
      if (r.norm() <= target) {
        result.solve_seconds += secondsSince(t0);
        step_shifted = false;  // CG solved with K itself
        return x;
      }
      z = factorSolve(r);
      const double rz_new = r.dot(z);
      p = z + (rz_new / rz) * p;
      rz = rz_new;
    }
    result.solve_seconds += secondsSince(t0);
    t0 = std::chrono::steady_clock::now();
  }
  if (!analysed) {
    factor.configure(nd(), threads);
    analysed = true;
  }
  factor_valid = factor.factorise(K);
  ++result.factorisations;
  if (!factor_valid) {
    if (result.factorisations == 1 && done == 0.0)
      throw SolveError(SolveFailure::kDegenerate,
                       "FEM: the stiffness at the rest state is singular: the fixtures do not hold the body against "
                       "rigid motion, or a piece of the mesh touches no fixture; widen the fixture regions");
    // A tangent at a far-off Newton iterate can be singular: the load step is retried smaller.
    return Eigen::VectorXd::Constant(n_free, std::numeric_limits<double>::quiet_NaN());
  }
  result.factorisation_seconds += secondsSince(t0);
  step_shifted = factor.shift() > 0.0;
  if (config.verbose && step_shifted)
    std::cerr << "fem: the tangent is not positive definite; factorised with a shift of " << factor.shift()
              << " x |diag K| (a descent step instead of Newton's)\n";
  if (config.verbose && result.factorisations == 1)
    std::cerr << "fem: " << n_free << " free dofs, nnz(K lower) " << K.nonZeros() << ", factor entries "
              << factor.factorEntries() << ", first factorisation " << secondsSince(t0) << " s\n";
  t0 = std::chrono::steady_clock::now();
  Eigen::VectorXd x = factorSolve(rhs);
  result.solve_seconds += secondsSince(t0);
  return x;
}

bool FemSolver::Impl::newton(double scale) {
  const int ndof = static_cast<int>(u.size());
  Eigen::VectorXd R, Kdu_c, du(ndof);
  double internal_norm = 0, last_update = std::numeric_limits<double>::infinity();
  failure = Failure::kStalled;
  for (int it = 0; it <= config.max_newton_iterations; ++it) {
    if (clock) {
      std::ostringstream state;
      state << "the state at load fraction " << done;
      clock->check(state.str());
    }
    // The constrained dofs move towards their targets as part of the Newton step so that large
    // prescribed displacements do not invert the first layer of elements.
    bool at_target = true;
    for (int d = 0; d < ndof; ++d) {
      du(d) = free_index[d] < 0 ? scale * prescribed(d) - u(d) : 0.0;
      if (free_index[d] < 0 && std::abs(du(d)) > 0) at_target = false;
    }
    auto t0 = std::chrono::steady_clock::now();
    const double e0 = assemble(u, scale, du, !at_target, R, Kdu_c, internal_norm);
    result.assembly_seconds += secondsSince(t0);
    if (!std::isfinite(e0)) {
      failure = Failure::kInverted;
      return false;
    }
    Eigen::VectorXd R_free(n_free);
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) R_free(free_index[d]) = R(d);
    const double res = R_free.norm(), ref = internal_norm + scale * f_ext.norm();
    // Reported relative to the load (to the reactions when only displacements load the body).
    const double load = scale * f_ext.norm() > 0.0 ? scale * f_ext.norm() : internal_norm;
    result.residual = load > 0.0 ? res / load : res;
    if (config.verbose) std::cerr << "fem: scale " << scale << " it " << it << " |R| " << res << " ref " << ref << "\n";
    if (clock) reportNewton(*clock, scale, result.newton_iterations, e0, result.residual);
    // Residuals of tiny loads drown in the round-off of P = mu (F - F^-T) + ..., so a vanishing
    // Newton update also counts as converged; a shifted step's does not (the shift shrinks it in
    // the soft directions, the ones that are still wrong).
    const bool update_vanished = it > 0 && !step_shifted && last_update <= config.displacement_tolerance * u.norm();
    if (at_target && (res <= config.tolerance * ref || update_vanished)) return true;
    if (it == config.max_newton_iterations) break;
    // Far from the answer a rough direction is as good as an exact one; close to it the forcing
    // term shrinks with the residual so the quadratic convergence is kept.
    const double eta = std::clamp(res / std::max(ref, 1e-300), 1e-10, 1e-4);
    const Eigen::VectorXd du_free = solveLinear(-(R_free + Kdu_c), eta);
    if (!du_free.allFinite()) return false;  // a singular tangent: stalled
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) du(d) = du_free(free_index[d]);
    ++result.newton_iterations;
    t0 = std::chrono::steady_clock::now();
    LineSearch step = backtrack([&](double alpha) { return energy(u + alpha * du, scale); }, e0, R.dot(du),
                                at_target);
    result.line_search_seconds += secondsSince(t0);
    if (!step.accepted) {
      if (!step.any_finite) failure = Failure::kInverted;
      if (!step.any_finite || !at_target || !residualFalls(du, scale, res)) return false;
      step.alpha = 1.0;
    }
    last_update = step.alpha * du.norm();
    u = u + step.alpha * du;
  }
  return false;
}

// Under a small load (a gentle push: 0.01 N on a 100 kPa body) the energy's changes near the
// answer are below the round-off of the energy itself, so no backtracked step shows a decrease and
// Newton stalled a few digits short, though its steps were still shrinking. The residual keeps
// its digits where the energy loses them, so there a full step is taken while it lowers the
// residual, or while the step itself vanishes (the next iteration then stops on the vanishing update,
// as for any round-off bound load).
bool FemSolver::Impl::residualFalls(const Eigen::VectorXd& du, double scale, double res) {
  if (du.norm() <= config.displacement_tolerance * u.norm()) return true;
  Eigen::VectorXd R, Kdu_c;
  double internal_norm = 0.0;
  const Eigen::VectorXd none = Eigen::VectorXd::Zero(u.size());
  if (!std::isfinite(assemble(u + du, scale, none, false, R, Kdu_c, internal_norm))) return false;
  double trial_res = 0.0;
  for (int d = 0; d < static_cast<int>(u.size()); ++d)
    if (free_index[d] >= 0) trial_res += R(d) * R(d);
  return std::sqrt(trial_res) < 0.5 * res;
}

const FemResult& FemSolver::solve() {
  impl_->clock = nullptr;
  return impl_->solveAll();
}

const FemResult& FemSolver::solve(const SolveControl& control) {
  SolveClock clock(control, "fem");
  return solve(clock);
}

const FemResult& FemSolver::solve(SolveClock& clock) {
  const AttachedClock attached(impl_->clock, clock);
  return impl_->solveAll();
}

void FemSolver::Impl::keepState() {
  result.displacement.resize(mesh.nodes.size());
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i) result.displacement[i] = u.segment<3>(3 * i);
}

const FemResult& FemSolver::Impl::solveAll() {
  const auto start = std::chrono::steady_clock::now();
  const int steps = std::max(1, config.load_steps > 0 ? config.load_steps : scenario.load_steps);
  const double nominal = 1.0 / steps;
  double step = nominal, done_before = -1.0;
  done = 0.0;
  int halvings = 0;
  bool all_inverted = true;
  result = FemResult{};
  Eigen::VectorXd u_before;
  while (done < 1.0 - 1e-12) {
    const double target = std::min(1.0, done + step);
    const Eigen::VectorXd saved = u;
    // Secant predictor from the last two converged load levels: in a large rotation (the T-bar
    // twist) the first Newton steps from the last state overshoot badly, from the extrapolated
    // state they start near the answer.
    if (done_before >= 0.0 && done > done_before) {
      const Eigen::VectorXd predicted = u + (target - done) / (done - done_before) * (u - u_before);
      if (std::isfinite(energy(predicted, target))) u = predicted;
    }
    bool converged = false;
    try {
      converged = newton(target);
    } catch (const SolveError&) {  // out of time or cancelled: keep the last converged state
      u = saved;
      keepState();
      result.seconds = secondsSince(start);
      throw;
    }
    if (converged) {
      done_before = done;
      u_before = saved;
      done = target;
      ++result.load_steps;
      step = std::min(nominal, 2.0 * step);
      continue;
    }
    u = saved;
    step *= 0.5;
    all_inverted = all_inverted && failure == Failure::kInverted;
    if (++halvings > config.max_step_halvings) {
      keepState();
      result.seconds = secondsSince(start);
      std::ostringstream msg;
      msg << "FEM: Newton did not converge at load fraction " << target << " even after " << config.max_step_halvings
          << " load-step halvings; kept the state at load fraction " << done << ". ";
      if (all_inverted)
        msg << "Every try inverted elements (det F <= 0): the load is beyond what the body carries, or the mesh has "
               "slivers; try a smaller load, more load_steps, or a finer, better-shaped mesh";
      else
        msg << "Newton stalled (residual " << result.residual << " of the load): raise max_newton_iterations or "
               "load_steps, or check that the fixtures hold the body";
      throw SolveError(all_inverted ? SolveFailure::kInverted : SolveFailure::kNotConverged, msg.str());
    }
  }
  keepState();
  result.energy = energy(u, 1.0);
  result.seconds = secondsSince(start);
  if (config.verbose)
    std::cerr << "fem: " << result.seconds << " s: assembly " << result.assembly_seconds << ", factorisation "
              << result.factorisation_seconds << " (" << result.factorisations << "), solves " << result.solve_seconds
              << " (" << result.cg_iterations << " CG its), line search " << result.line_search_seconds << "; "
              << result.newton_iterations << " Newton its, " << colours.size() << " colours, " << threads
              << " threads\n";
  if (clock) {
    SolveProgress progress;
    progress.phase = "done";
    progress.load_fraction = 1.0;
    progress.iteration = result.newton_iterations;
    progress.energy = result.energy;
    progress.residual = result.residual;
    clock->report(progress, true);
  }
  return result;
}

}  // namespace demnerf::mechanics
