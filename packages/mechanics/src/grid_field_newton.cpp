#include "demnerf/mechanics/grid_field_newton.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "demnerf/core/error.hpp"
#include "extended_unknowns.hpp"
#include "fill_reducing_order.hpp"
#include "grid_field_energy.hpp"
#include "parallel_for.hpp"
#include "shifted_cholesky.hpp"
#include "weak_hold.hpp"

namespace demnerf::mechanics {
namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Nested dissection (fill_reducing_order.hpp) of the unknown nodes' coupling graph, split by their
// grid coordinates: the grid's Hessian is a 3-D lattice graph, which dissection orders with far
// less fill than AMD once the extension has widened its couplings.
std::vector<int> eliminationOrder(const GridFieldEnergy& energy, const Unknowns& unknowns, const BsplineGrid& grid) {
  const auto& couplings = energy.couplings();
  const int n = static_cast<int>(couplings.size());
  std::vector<std::vector<int>> adjacency(n);
  for (int b = 0; b < n; ++b)
    for (long a : couplings[b]) {
      adjacency[b].push_back(static_cast<int>(a));
      if (a != b) adjacency[a].push_back(b);
    }
  std::vector<int> adj_start(n + 1, 0), adj;
  for (int b = 0; b < n; ++b) {
    std::sort(adjacency[b].begin(), adjacency[b].end());
    adj.insert(adj.end(), adjacency[b].begin(), adjacency[b].end());
    adj_start[b + 1] = static_cast<int>(adj.size());
  }
  const Eigen::Vector3i nn = grid.cells() + Eigen::Vector3i::Constant(grid.degree());
  std::vector<Eigen::Vector3d> x(n);
  for (int r = 0; r < n; ++r) {
    const long a = energy.activeNodes()[unknowns.activeOfUnknown(r)];
    x[r] = Eigen::Vector3d(a % nn(0), (a / nn(0)) % nn(1), a / (nn(0) * nn(1)));
  }
  return nestedDissection(x, adj_start, adj);
}

// The unknowns a factorisation belongs to: the active nodes and which of them are unknowns.
std::vector<long> unknownNodes(const GridFieldEnergy& energy, const Unknowns& unknowns) {
  std::vector<long> key = energy.activeNodes();
  key.push_back(-1);
  for (long r = 0; r < static_cast<long>(energy.couplings().size()); ++r) key.push_back(unknowns.activeOfUnknown(r));
  return key;
}

}  // namespace

struct GridNewtonCache::State {
  std::vector<long> unknown_nodes;
  ShiftedCholesky solver;
  int hold_rung = 0;  // the widest weak-hold rung a call on these unknowns needed (weak_hold.cpp)
};

GridNewtonCache::GridNewtonCache() = default;
GridNewtonCache::~GridNewtonCache() = default;
GridNewtonCache::GridNewtonCache(GridNewtonCache&&) noexcept = default;
GridNewtonCache& GridNewtonCache::operator=(GridNewtonCache&&) noexcept = default;

namespace {

// The current Newton iterate: reduced unknowns r, the full coefficients c = E r, and their energy.
struct Iterate {
  Eigen::VectorXd r, c;
  double energy = 0.0, strain = 0.0, min_J = 0.0;
};

// The state r, if admissible (finite energy); `iterate` is left as it was otherwise.
bool moveTo(const GridFieldEnergy& energy, const Unknowns& unknowns, const Eigen::VectorXd& r, Iterate& iterate) {
  Iterate trial;
  trial.r = r;
  trial.c = unknowns.full(r);
  trial.energy = energy.energy(trial.c, &trial.strain, &trial.min_J);
  if (!std::isfinite(trial.energy)) return false;
  iterate = std::move(trial);
  return true;
}

// The start from the caller's coefficients, projected onto the extended basis (outer nodes
// extrapolated). False when neither it nor the grid's share off is admissible.
bool startingPoint(const GridFieldEnergy& energy, const Unknowns& unknowns, const Eigen::MatrixXd& C, Iterate& iterate) {
  const auto& active = energy.activeNodes();
  Eigen::VectorXd c(energy.unknowns());
  for (std::size_t l = 0; l < active.size(); ++l) c.segment<3>(3 * l) = C.row(active[l]).transpose();
  const Eigen::VectorXd r = unknowns.reduce(c);
  if (moveTo(energy, unknowns, r, iterate)) return true;
  // An inadmissible start (a larger load than the coefficients were solved for): the grid's
  // share off is admissible whenever u_0 is.
  if (moveTo(energy, unknowns, Eigen::VectorXd::Zero(r.size()), iterate)) return true;
  iterate.energy = std::numeric_limits<double>::infinity();
  return false;
}

// The linear solver of these unknowns: the cache's when it was made for them, else a new one.
GridNewtonCache::State& linearSolver(GridNewtonCache& cache, const GridFieldEnergy& energy, const Unknowns& unknowns,
                                     const BsplineGrid& grid, int threads, bool near_minimum) {
  std::vector<long> unknown_nodes = unknownNodes(energy, unknowns);
  if (!cache.state || cache.state->unknown_nodes != unknown_nodes) {
    cache.state = std::make_unique<GridNewtonCache::State>();
    cache.state->unknown_nodes = std::move(unknown_nodes);
    cache.state->solver.setNodeOrder(eliminationOrder(energy, unknowns, grid));
    cache.state->solver.setThreads(assemblyThreads(threads));
    if (near_minimum) cache.state->solver.tryUnshiftedFirst();
  }
  return *cache.state;
}

// Backtracking (Armijo) along `step`; inverted states have infinite energy and are rejected.
// `full` says whether the whole step was taken.
bool lineSearch(const GridFieldEnergy& energy, const Unknowns& unknowns, const Eigen::VectorXd& step, double decrement,
                Iterate& iterate, bool& full) {
  for (double alpha = 1.0; alpha > 1e-6; alpha *= 0.5) {
    Iterate trial;
    if (moveTo(energy, unknowns, iterate.r + alpha * step, trial) &&
        trial.energy <= iterate.energy - 1e-4 * alpha * decrement) {
      iterate = std::move(trial);
      full = alpha == 1.0;
      return true;
    }
  }
  return false;
}

// The gradient at the iterate (in the unknowns) and the Hessian there. In Newton's quadratic phase
// the residual is mostly converged already: the gradient alone (a fraction of an assembly) is
// computed first, and the Hessian skipped when its norm is within `converged` (Newton stops there).
void assembleAt(const GridFieldEnergy& energy, const Unknowns& unknowns, const Iterate& x, bool quadratic,
                bool projected, double converged, const std::vector<char>& weak, Eigen::VectorXd& gradient,
                Eigen::SparseMatrix<double>& hessian) {
  if (quadratic) {
    gradient = unknowns.projectGradient(energy.gradient(x.c));
    holdWeak(weak, gradient, nullptr);
    if (gradient.norm() <= converged) return;
  }
  energy.derivatives(x.c, gradient, hessian, projected);
  gradient = unknowns.projectGradient(gradient);
  holdWeak(weak, gradient, &hessian);
}

// At the held equilibrium, lets the held unknowns go when the Hessian without the hold is positive
// definite there: the singularity was the start's (a coarse level's answer moved to the fine grid,
// a first step's state), not the body's, and Newton goes on to the minimiser in the whole basis.
// True when released; the free gradient and Hessian at the iterate are then in `gradient` and `hessian`, the
// next iteration's. A body whose Hessian stays singular (the fox's sponge, slivers) keeps the hold,
// at the price of one assembly and one factorisation.
bool releaseHeld(const WeakHoldInputs& inputs, ShiftedCholesky& solver, const GridNewtonConfig& config, double load,
                 WeakHold& hold, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>& hessian) {
  if (!config.release_held || hold.held == 0 || hold.released > 0) return false;
  Eigen::VectorXd free_gradient;
  Eigen::SparseMatrix<double> free_hessian;
  inputs.free_derivatives(free_gradient, free_hessian);
  // The held unknowns in balance as well: nothing to gain.
  if (free_gradient.norm() <= config.residual_tolerance * load) return false;
  if (!solver.factoriseUnshifted(free_hessian)) return false;
  hold.released = hold.held;
  hold.held = 0;
  hold.weak.clear();
  gradient = std::move(free_gradient);
  hessian = std::move(free_hessian);
  return true;
}

// The weak hold's inputs at the current iterate `x` (referenced, so always the loop's).
WeakHoldInputs weakHoldInputs(const GridFieldProblem& problem, const BsplineGrid& grid, const GridFieldEnergy& energy,
                              const Unknowns& unknowns, const Iterate& x) {
  WeakHoldInputs inputs;
  inputs.cover = [&] { return relativeCover(problem, grid, energy.activeNodes(), unknowns); };
  inputs.free_derivatives = [&](Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>& hessian) {
    energy.derivatives(x.c, gradient, hessian, false);
    gradient = unknowns.projectGradient(gradient);
  };
  return inputs;
}

// The residual the held unknowns would have if they were free, relative to the same load: the
// answer is an equilibrium of the body with them held, and this says how far from one without.
double heldResidual(const GridFieldEnergy& energy, const Unknowns& unknowns, const Iterate& x,
                    const std::vector<char>& weak, double load) {
  const Eigen::VectorXd full = unknowns.projectGradient(energy.gradient(x.c));
  double sum = 0.0;
  for (Eigen::Index k = 0; k < full.size(); ++k)
    if (weak[k]) sum += full(k) * full(k);
  return load > 0 ? std::sqrt(sum) / load : 0.0;
}

// The caller's per-iteration report; if it throws (a stop request), the iterate reached so far is
// stored in the caller's coefficients first.
template <typename Store>
void notifyIteration(const GridNewtonConfig& config, int it, double energy, double residual, const Store& store) {
  if (!config.on_iteration) return;
  try {
    config.on_iteration(it, energy, residual);
  } catch (...) {
    store();
    throw;
  }
}

// The outcome's hold, energies and smallest det F at the returned iterate.
void finish(const GridFieldEnergy& energy, const Unknowns& unknowns, const Iterate& x, const WeakHold& hold,
            double load, GridNewtonCache::State& state, int factorisations_before, GridNewtonOutcome& out) {
  out.factorisations = state.solver.factorisations() - factorisations_before;
  state.hold_rung = std::max(state.hold_rung, hold.rung);  // the next call's ladder starts there
  out.held = hold.held;
  out.released = hold.released;
  out.hold_rung = hold.rung;
  if (out.held > 0) out.held_residual = heldResidual(energy, unknowns, x, hold.weak, load);
  out.energy = x.energy;
  out.strain_energy = x.strain;
  out.min_J = x.min_J;
}

}  // namespace

GridNewtonOutcome minimiseGridField(const GridFieldProblem& problem, const HyperelasticMaterial& material,
                                    const BsplineGrid& grid, Eigen::MatrixXd& C, const GridNewtonConfig& config) {
  if (C.rows() != grid.nodeCount() || C.cols() != 3)
    throw core::Error("grid field coefficients must be nodeCount x 3");
  GridFieldEnergy energy(problem, material, grid, config.threads);
  const auto& active = energy.activeNodes();
  const Unknowns unknowns(problem, grid, active, config.extension_fill);
  energy.setUnknownMap(unknowns.nodeMap());
  GridNewtonOutcome out;
  Iterate x;
  if (!startingPoint(energy, unknowns, C, x)) {
    out.energy = x.energy;
    return out;
  }
  GridNewtonCache local;
  GridNewtonCache::State& state = linearSolver(config.cache ? *config.cache : local, energy, unknowns, grid,
                                               config.threads, config.near_minimum);
  ShiftedCholesky& solver = state.solver;
  const int factorisations_before = solver.factorisations();
  const auto store = [&] {
    for (std::size_t l = 0; l < active.size(); ++l) C.row(active[l]) = x.c.segment<3>(3 * l).transpose();
  };
  // The residual's measure: the external forces, or (a prescribed displacement alone) the start's internal ones.
  double load = energy.externalNorm();
  int rounding_steps = 0;
  Eigen::VectorXd gradient;
  Eigen::SparseMatrix<double> hessian;
  WeakHold hold{state.hold_rung};  // held unknowns (weakHoldStep), for the whole call unless released
  const WeakHoldInputs hold_inputs = weakHoldInputs(problem, grid, energy, unknowns, x);
  // The last step was a full one from a residual this small: Newton's quadratic phase, where the
  // next residual is about its square (T-bar twist: 1.3e-6 -> 1.9e-12, 1.9e-2 -> 1.3e-6).
  constexpr double kQuadraticPhase = 1e-3;
  bool quadratic = false;
  bool assembled = false;  // gradient and hessian are already x's (a release assembled them)
  for (int it = 0;; ++it) {
    auto start = std::chrono::steady_clock::now();
    if (!assembled)
      assembleAt(energy, unknowns, x, quadratic, config.projected_start && it == 0, config.residual_tolerance * load,
                 hold.weak, gradient, hessian);
    assembled = false;
    out.assembly_seconds += secondsSince(start);
    if (it == 0) load = std::max(load, gradient.norm());
    out.residual = load > 0 ? gradient.norm() / load : 0.0;
    notifyIteration(config, it, x.energy, out.residual, store);
    if (out.residual <= config.residual_tolerance) {
      start = std::chrono::steady_clock::now();
      assembled = releaseHeld(hold_inputs, solver, config, load, hold, gradient, hessian);
      out.assembly_seconds += secondsSince(start);
      if (assembled) continue;  // Newton goes on in the whole basis
      out.converged = true;
      break;
    }
    if (it >= config.max_iterations) break;
    start = std::chrono::steady_clock::now();
    const Eigen::VectorXd step = weakHoldStep(solver, hessian, gradient, config, hold_inputs, hold);
    out.factorisation_seconds += secondsSince(start);
    const double decrement = -gradient.dot(step);
    if (!(decrement > 0) || !std::isfinite(decrement)) break;
    ++out.iterations;
    // Near the minimum the energy cannot resolve a Newton step (its decrease is below the rounding
    // of the energy): the full step is taken on the residual's word, if it stays admissible.
    if (decrement <= config.tolerance * std::max(std::abs(x.energy), x.strain)) {
      if (++rounding_steps > 3 || !moveTo(energy, unknowns, x.r + step, x)) {
        --out.iterations;
        break;
      }
      quadratic = out.residual <= kQuadraticPhase;
      continue;
    }
    start = std::chrono::steady_clock::now();
    bool full = false;
    const bool moved = lineSearch(energy, unknowns, step, decrement, x, full);
    out.line_search_seconds += secondsSince(start);
    if (!moved) break;
    quadratic = full && out.residual <= kQuadraticPhase;
  }
  store();
  finish(energy, unknowns, x, hold, load, state, factorisations_before, out);
  return out;
}

}  // namespace demnerf::mechanics
