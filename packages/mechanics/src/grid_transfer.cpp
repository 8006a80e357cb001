#include "grid_transfer.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <string>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/bspline_extension.hpp"
#include "supernodal_cholesky.hpp"

namespace demnerf::mechanics {
namespace {

// M^-1 b for the symmetric positive definite mass matrix M (both triangles stored): in AMD's order
// by the supernodal Cholesky (supernodal_cholesky.hpp, dense kernels for this CPU), which took a
// third of the simplicial LDL^T's time on the T-bar's 4.6k nodes (about 0.2 CPU-s a solve). The
// simplicial LDL^T remains the fallback for a matrix the Cholesky refuses.
Eigen::MatrixXd solveMass(const Eigen::SparseMatrix<double>& M, const Eigen::MatrixXd& b) {
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
  Eigen::AMDOrdering<int>()(M, order);
  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P = order.inverse();
  Eigen::SparseMatrix<double> lower(M.rows(), M.cols());
  lower.selfadjointView<Eigen::Lower>() = M.selfadjointView<Eigen::Lower>().twistedBy(P);
  SupernodalCholesky cholesky;
  cholesky.analyse(lower);
  if (cholesky.factorise(lower)) {
    Eigen::MatrixXd x(b.rows(), b.cols());
    for (Eigen::Index k = 0; k < b.cols(); ++k) x.col(k) = P.transpose() * cholesky.solve(P * b.col(k));
    return x;
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> factor(M);
  if (factor.info() != Eigen::Success) throw core::Error("grid transfer: the mass matrix could not be factorised");
  return factor.solve(b);
}

}  // namespace

Eigen::MatrixXd transferGridField(const BsplineGrid& from, const Eigen::MatrixXd& C_from, const BsplineGrid& to,
                                  const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights) {
  if (C_from.rows() != from.nodeCount() || C_from.cols() != 3)
    throw core::Error("grid transfer: the coefficients must be nodeCount x 3 of the grid they belong to");
  if (points.size() != weights.size())
    throw core::Error("grid transfer: " + std::to_string(points.size()) + " points but " +
                      std::to_string(weights.size()) + " weights");
  const int S_from = from.supportSize(), S_to = to.supportSize();
  std::vector<long> nodes_from(S_from), nodes_to(S_to);
  std::vector<double> N_from(S_from), N_to(S_to);
  std::vector<Eigen::Vector3d> unused(std::max(S_from, S_to));
  // The normal equations M C = b on the nodes the points see (M: the weighted mass matrix), summed
  // per cell of `to` (its points share their nodes) and scattered once per cell.
  std::vector<std::size_t> order;
  std::vector<long> cell_of(points.size());
  for (std::size_t q = 0; q < points.size(); ++q)
    if (weights[q] > 0) {
      order.push_back(q);
      cell_of[q] = to.cellIndex(points[q]);
    }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cell_of[a] < cell_of[b]; });
  std::vector<long> local(to.nodeCount(), -1), active;
  std::vector<Eigen::Triplet<double>> entries;
  std::vector<Eigen::Vector3d> rhs;
  Eigen::MatrixXd block(S_to, S_to);
  for (std::size_t k = 0; k < order.size();) {
    block.setZero();
    const long cell = cell_of[order[k]];
    for (; k < order.size() && cell_of[order[k]] == cell; ++k) {
      const std::size_t q = order[k];
      from.evaluate(points[q], nodes_from.data(), N_from.data(), unused.data());
      to.evaluate(points[q], nodes_to.data(), N_to.data(), unused.data());
      Eigen::Vector3d value = Eigen::Vector3d::Zero();
      for (int s = 0; s < S_from; ++s) value += N_from[s] * C_from.row(nodes_from[s]).transpose();
      const Eigen::Map<const Eigen::VectorXd> phi(N_to.data(), S_to);
      block.noalias() += weights[q] * phi * phi.transpose();
      for (int s = 0; s < S_to; ++s) {
        long& l = local[nodes_to[s]];
        if (l < 0) {
          l = static_cast<long>(active.size());
          active.push_back(nodes_to[s]);
          rhs.emplace_back(Eigen::Vector3d::Zero());
        }
        rhs[l] += weights[q] * N_to[s] * value;
      }
    }
    // Every point of a cell has the same nodes: the last point's are the cell's.
    for (int s = 0; s < S_to; ++s)
      for (int t = 0; t < S_to; ++t)
        entries.emplace_back(local[nodes_to[s]], local[nodes_to[t]], block(s, t));
  }
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(to.nodeCount(), 3);
  const long n = static_cast<long>(active.size());
  if (n == 0) return C;
  Eigen::SparseMatrix<double> M(n, n);
  M.setFromTriplets(entries.begin(), entries.end());
  // A node whose support the points barely reach has a tiny column, nearly dependent on its
  // neighbours': a ridge of 1e-10 of the mean diagonal keeps the factorisation defined and moves
  // the well-seen nodes by rounding only (the Newton's extension then replaces such nodes anyway).
  const double ridge = 1e-10 * M.diagonal().mean();
  for (long a = 0; a < n; ++a) M.coeffRef(a, a) += ridge;
  Eigen::MatrixXd b(n, 3);
  for (long a = 0; a < n; ++a) b.row(a) = rhs[a].transpose();
  const Eigen::MatrixXd solved = solveMass(M, b);
  for (long a = 0; a < n; ++a) C.row(active[a]) = solved.row(a);
  return C;
}

namespace {

// The nodes of the cells that hold one of `points` ("seen", 1) and, of the cells that hold a target
// but no point, the other nodes (2). One basis evaluation per cell: a cell's points share their nodes.
std::vector<char> nodeStates(const BsplineGrid& grid, const std::vector<Eigen::Vector3d>& points,
                             const std::vector<double>& weights, const std::vector<Eigen::Vector3d>& targets) {
  const auto cells = static_cast<std::size_t>(grid.cells().cast<long>().prod());
  std::vector<const Eigen::Vector3d*> seen_in(cells, nullptr), reached_in(cells, nullptr);
  for (std::size_t q = 0; q < points.size(); ++q)
    if (weights[q] > 0) seen_in[grid.cellIndex(points[q])] = &points[q];
  for (const Eigen::Vector3d& x : targets) reached_in[grid.cellIndex(x)] = &x;
  const int S = grid.supportSize();
  std::vector<long> support(S);
  std::vector<double> N(S);
  std::vector<Eigen::Vector3d> unused(S);
  std::vector<char> state(grid.nodeCount(), 0);
  for (const auto* x : seen_in)
    if (x) {
      grid.evaluate(*x, support.data(), N.data(), unused.data());
      for (long a : support) state[a] = 1;
    }
  for (std::size_t cell = 0; cell < reached_in.size(); ++cell)
    if (reached_in[cell] && !seen_in[cell]) {
      grid.evaluate(*reached_in[cell], support.data(), N.data(), unused.data());
      for (long a : support)
        if (state[a] == 0) state[a] = 2;
    }
  return state;
}

}  // namespace

long continueUnseenNodes(const BsplineGrid& grid, Eigen::MatrixXd& C, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<double>& weights, const std::vector<Eigen::Vector3d>& targets, double fill) {
  if (C.rows() != grid.nodeCount() || C.cols() != 3 || points.size() != weights.size())
    throw core::Error("grid continuation: C must be nodeCount x 3 and the points as many as their weights");
  const std::vector<char> state = nodeStates(grid, points, weights, targets);
  if (std::find(state.begin(), state.end(), 2) == state.end()) return 0;
  std::vector<long> nodes;
  for (long a = 0; a < grid.nodeCount(); ++a)
    if (state[a] != 0) nodes.push_back(a);
  const BsplineExtension ext = extendOuterNodes(grid, nodes, quadratureCellFill(grid, points, weights), fill);
  // An extrapolated row reads the nodes of a filled cell, which its points see: the continued
  // values come from solved coefficients alone. A kept row (no filled cell within reach) is left.
  const Eigen::SparseMatrix<double, Eigen::RowMajor> map = ext.map;
  long continued = 0;
  for (Eigen::Index l = 0; l < map.outerSize(); ++l) {
    if (state[nodes[l]] != 2) continue;
    Eigen::Vector3d value = Eigen::Vector3d::Zero();
    bool extrapolated = false;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(map, l); it; ++it) {
      const long from = nodes[ext.kept[it.col()]];
      extrapolated |= from != nodes[l];
      value += it.value() * C.row(from).transpose();
    }
    if (!extrapolated) continue;
    C.row(nodes[l]) = value.transpose();
    ++continued;
  }
  return continued;
}

}  // namespace demnerf::mechanics
