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
ShiftedCholesky& linearSolver(GridNewtonCache& cache, const GridFieldEnergy& energy, const Unknowns& unknowns,
                              const BsplineGrid& grid, int threads, bool near_minimum) {
  std::vector<long> unknown_nodes = unknownNodes(energy, unknowns);
  if (!cache.state || cache.state->unknown_nodes != unknown_nodes) {
    cache.state = std::make_unique<GridNewtonCache::State>();
    cache.state->unknown_nodes = std::move(unknown_nodes);
    cache.state->solver.setNodeOrder(eliminationOrder(energy, unknowns, grid));
    cache.state->solver.setThreads(assemblyThreads(threads));
    if (near_minimum) cache.state->solver.tryUnshiftedFirst();
  }
  return cache.state->solver;
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

// The unknowns whose stiffness (Hessian diagonal) at the start is below `ratio` of the mean: grid
// functions the body barely sees, e.g. those the distance factor D of a fixture all but cancels at
// every point they reach. On the fox's ragged NeRF body they made the Hessian singular at rest
// (covers 1e-4 .. 1e-8 of a cell): Lanczos saw no negative curvature, every factorisation needed
// the fallback shift of 1e-3, and that shift stalled the body's soft bending modes (residual
// 2e-3 after 21 iterations of a 300 s budget; docs/dem_feature_grid.md, "Ragged bodies").
std::vector<char> weakUnknowns(const Eigen::SparseMatrix<double>& hessian, double ratio, long& count) {
  const Eigen::VectorXd diagonal = hessian.diagonal().cwiseAbs();
  std::vector<char> weak(diagonal.size(), 0);
  count = 0;
  if (!(ratio > 0) || diagonal.size() == 0) return weak;
  const double floor = ratio * diagonal.mean();
  for (Eigen::Index k = 0; k < diagonal.size(); ++k) count += weak[k] = diagonal(k) < floor;
  return weak;
}

// Holds the weak unknowns where they are: no gradient, no coupling and the mean diagonal as pivot,
// so the factorisation needs no shift for them and the residual is the other unknowns'. Only for a
// Hessian found singular: holding them always stiffened a clamped cantilever by 2.7 % in energy and
// put the T-bar 5.8 % off (the weak unknowns beside a clamp carry its field), and damping them alone
// instead stalled their own convergence on clean bodies.
void holdWeak(const std::vector<char>& weak, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>* hessian) {
  if (weak.empty()) return;
  for (Eigen::Index k = 0; k < gradient.size(); ++k)
    if (weak[k]) gradient(k) = 0.0;
  if (!hessian || hessian->nonZeros() == 0) return;
  const double mean = std::max(hessian->diagonal().cwiseAbs().mean(), std::numeric_limits<double>::min());
  for (int col = 0; col < hessian->outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(*hessian, col); it; ++it)
      if (weak[it.row()] || weak[it.col()]) it.valueRef() = it.row() == it.col() ? mean : 0.0;
}

// The Newton step; the first time a factorisation finds the Hessian singular, its weak unknowns
// are held from then on (`weak`, `held`) and the step is taken again without them. Not only at
// the first iteration: a fine grid started from a coarse answer factorises its first Hessian
// unshifted (near_minimum) and met the singularity later (the fox's freshly trained sponge:
// residual falling 0.7x per iteration under the shift, no equilibrium in 200 s).
Eigen::VectorXd newtonStep(ShiftedCholesky& solver, Eigen::SparseMatrix<double>& hessian, Eigen::VectorXd& gradient,
                           const GridNewtonConfig& config, std::vector<char>& weak, long& held) {
  Eigen::VectorXd step = solver.solve(hessian, -gradient, config.initial_shift);
  if (held > 0 || !solver.singular() || !(config.weak_stiffness > 0)) return step;
  weak = weakUnknowns(hessian, config.weak_stiffness, held);
  if (held == 0) return step;
  holdWeak(weak, gradient, &hessian);
  return solver.solve(hessian, -gradient, config.initial_shift);
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

// The outcome's energies and smallest det F at the returned iterate.
void setEnergies(const Iterate& x, GridNewtonOutcome& out) {
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
  ShiftedCholesky& solver = linearSolver(config.cache ? *config.cache : local, energy, unknowns, grid, config.threads,
                                         config.near_minimum);
  const int factorisations_before = solver.factorisations();
  const auto store = [&] {
    for (std::size_t l = 0; l < active.size(); ++l) C.row(active[l]) = x.c.segment<3>(3 * l).transpose();
  };
  // The load the residual is measured against: the external forces, or (a prescribed displacement
  // alone) the internal forces of the start.
  double load = energy.externalNorm();
  int rounding_steps = 0;
  Eigen::VectorXd gradient;
  Eigen::SparseMatrix<double> hessian;
  std::vector<char> weak;  // held unknowns (newtonStep), for the whole call
  // The last step was a full one from a residual this small: Newton's quadratic phase, where the
  // next residual is about its square (T-bar twist: 1.3e-6 -> 1.9e-12, 1.9e-2 -> 1.3e-6).
  constexpr double kQuadraticPhase = 1e-3;
  bool quadratic = false;
  for (int it = 0;; ++it) {
    auto start = std::chrono::steady_clock::now();
    assembleAt(energy, unknowns, x, quadratic, config.projected_start && it == 0, config.residual_tolerance * load,
               weak, gradient, hessian);
    out.assembly_seconds += secondsSince(start);
    if (it == 0) load = std::max(load, gradient.norm());
    out.residual = load > 0 ? gradient.norm() / load : 0.0;
    if (config.on_iteration) {
      try {
        config.on_iteration(it, x.energy, out.residual);
      } catch (...) {
        store();
        throw;
      }
    }
    if (out.residual <= config.residual_tolerance) {
      out.converged = true;
      break;
    }
    if (it >= config.max_iterations) break;
    start = std::chrono::steady_clock::now();
    const Eigen::VectorXd step = newtonStep(solver, hessian, gradient, config, weak, out.held);
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
  if (out.held > 0) out.held_residual = heldResidual(energy, unknowns, x, weak, load);
  out.factorisations = solver.factorisations() - factorisations_before;
  store();
  setEnergies(x, out);
  return out;
}

}  // namespace demnerf::mechanics
