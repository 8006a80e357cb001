#include "demnerf/mechanics/grid_field_newton.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "extended_unknowns.hpp"
#include "fill_reducing_order.hpp"
#include "grid_field_energy.hpp"
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

}  // namespace

GridNewtonOutcome minimiseGridField(const GridFieldProblem& problem, const HyperelasticMaterial& material,
                                    const BsplineGrid& grid, Eigen::MatrixXd& C, const GridNewtonConfig& config) {
  if (C.rows() != grid.nodeCount() || C.cols() != 3)
    throw core::Error("grid field coefficients must be nodeCount x 3");
  GridFieldEnergy energy(problem, material, grid, config.threads);
  const auto& active = energy.activeNodes();
  const Unknowns unknowns(problem, grid, active, config.extension_fill);
  energy.setUnknownMap(unknowns.nodeMap());
  Eigen::VectorXd c(energy.unknowns());
  for (std::size_t l = 0; l < active.size(); ++l) c.segment<3>(3 * l) = C.row(active[l]).transpose();
  // With the extension the start is projected onto the extended basis (outer nodes extrapolated).
  Eigen::VectorXd r = unknowns.reduce(c);
  c = unknowns.full(r);
  GridNewtonOutcome out;
  double strain = 0.0;
  double current = energy.energy(c, &strain, &out.min_J);
  if (!std::isfinite(current)) {
    // An inadmissible start (a larger load than the coefficients were solved for): the grid's
    // share off is admissible whenever u_0 is.
    r.setZero();
    c.setZero();
    current = energy.energy(c, &strain, &out.min_J);
    if (!std::isfinite(current)) {
      out.energy = current;
      return out;
    }
  }
  Eigen::VectorXd gradient;
  Eigen::SparseMatrix<double> hessian;
  ShiftedCholesky solver;
  solver.setNodeOrder(eliminationOrder(energy, unknowns, grid));
  const auto store = [&] {
    for (std::size_t l = 0; l < active.size(); ++l) C.row(active[l]) = c.segment<3>(3 * l).transpose();
  };
  // The load the residual is measured against: the external forces, or (a prescribed displacement
  // alone) the internal forces of the start.
  double load = energy.externalNorm();
  int rounding_steps = 0;
  for (int it = 0;; ++it) {
    auto start = std::chrono::steady_clock::now();
    energy.derivatives(c, gradient, hessian);
    gradient = unknowns.projectGradient(gradient);
    out.assembly_seconds += secondsSince(start);
    if (it == 0) load = std::max(load, gradient.norm());
    out.residual = load > 0 ? gradient.norm() / load : 0.0;
    if (config.on_iteration) {
      try {
        config.on_iteration(it, current, out.residual);
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
    const Eigen::VectorXd step = solver.solve(hessian, -gradient, config.initial_shift);
    out.factorisation_seconds += secondsSince(start);
    const double decrement = -gradient.dot(step);
    if (!(decrement > 0) || !std::isfinite(decrement)) break;
    // Near the minimum the energy cannot resolve a Newton step (its decrease is below the rounding
    // of the energy): the full step is taken on the residual's word, if it stays admissible.
    if (decrement <= config.tolerance * std::max(std::abs(current), strain)) {
      double trial_strain = 0.0, trial_J = 0.0;
      const Eigen::VectorXd trial = r + step;
      const Eigen::VectorXd trial_c = unknowns.full(trial);
      const double e = energy.energy(trial_c, &trial_strain, &trial_J);
      if (!std::isfinite(e) || ++rounding_steps > 3) break;
      r = trial;
      c = trial_c;
      current = e;
      strain = trial_strain;
      out.min_J = trial_J;
      ++out.iterations;
      continue;
    }
    // Backtracking (Armijo) line search; inverted states have infinite energy and are rejected.
    bool moved = false;
    start = std::chrono::steady_clock::now();
    for (double alpha = 1.0; alpha > 1e-6; alpha *= 0.5) {
      const Eigen::VectorXd trial = r + alpha * step;
      const Eigen::VectorXd trial_c = unknowns.full(trial);
      double trial_strain = 0.0, trial_J = 0.0;
      const double e = energy.energy(trial_c, &trial_strain, &trial_J);
      if (std::isfinite(e) && e <= current - 1e-4 * alpha * decrement) {
        r = trial;
        c = trial_c;
        current = e;
        strain = trial_strain;
        out.min_J = trial_J;
        moved = true;
        break;
      }
    }
    out.line_search_seconds += secondsSince(start);
    ++out.iterations;
    if (!moved) break;
  }
  store();
  out.energy = current;
  out.strain_energy = strain;
  return out;
}

}  // namespace demnerf::mechanics
