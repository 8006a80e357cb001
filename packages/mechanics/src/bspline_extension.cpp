#include "demnerf/mechanics/bspline_extension.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

// Lagrange weight of node index `i` (one of first .. first + degree) at index j.
double lagrange(int first, int degree, int i, int j) {
  double w = 1.0;
  for (int m = first; m <= first + degree; ++m)
    if (m != i) w *= static_cast<double>(j - m) / static_cast<double>(i - m);
  return w;
}

}  // namespace

std::vector<double> quadratureCellFill(const BsplineGrid& grid, const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<double>& weights) {
  std::vector<double> fill(static_cast<std::size_t>(grid.cells().cast<long>().prod()), 0.0);
  const double cell_volume = std::pow(grid.cell(), 3);
  for (std::size_t q = 0; q < points.size(); ++q) fill[grid.cellIndex(points[q])] += weights[q] / cell_volume;
  return fill;
}

BsplineExtension extendOuterNodes(const BsplineGrid& grid, const std::vector<long>& nodes,
                                  const std::vector<double>& cell_fill, double full) {
  const Eigen::Vector3i cells = grid.cells();
  const int p = grid.degree();
  const long cell_count = static_cast<long>(cells(0)) * cells(1) * cells(2);
  if (static_cast<long>(cell_fill.size()) != cell_count)
    throw core::Error("B-spline extension: cell_fill has " + std::to_string(cell_fill.size()) + " entries, the grid " +
                      std::to_string(cell_count) + " cells");
  const Eigen::Vector3i nn = cells + Eigen::Vector3i::Constant(p);
  const auto nodeIjk = [&](long a) { return Eigen::Vector3i(a % nn(0), (a / nn(0)) % nn(1), a / (nn(0) * nn(1))); };
  const auto nodeId = [&](const Eigen::Vector3i& v) { return (static_cast<long>(v(2)) * nn(1) + v(1)) * nn(0) + v(0); };
  const auto cellId = [&](const Eigen::Vector3i& c) { return (static_cast<long>(c(2)) * cells(1) + c(1)) * cells(0) + c(0); };
  const auto inner = [&](const Eigen::Vector3i& c) {
    return (c.array() >= 0).all() && (c.array() < cells.array()).all() && cell_fill[cellId(c)] >= full;
  };
  // Node a (index v) is non-zero on cells v - p .. v per axis.
  const auto touchesInner = [&](const Eigen::Vector3i& v) {
    for (int k = v(2) - p; k <= v(2); ++k)
      for (int j = v(1) - p; j <= v(1); ++j)
        for (int i = v(0) - p; i <= v(0); ++i)
          if (inner({i, j, k})) return true;
    return false;
  };
  // The nearest inner cell to a node (by index distance to the node's support), or none.
  const int reach = 2 * (p + 1);
  const auto nearestInner = [&](const Eigen::Vector3i& v, Eigen::Vector3i& best) {
    double best_d = std::numeric_limits<double>::infinity();
    for (int k = v(2) - p - reach; k <= v(2) + reach; ++k)
      for (int j = v(1) - p - reach; j <= v(1) + reach; ++j)
        for (int i = v(0) - p - reach; i <= v(0) + reach; ++i) {
          if (!inner({i, j, k})) continue;
          // Distance from the cell's nodes' centre (c + p / 2) to the node.
          const Eigen::Vector3d d = Eigen::Vector3d(i, j, k) + Eigen::Vector3d::Constant(0.5 * p) - v.cast<double>();
          if (d.squaredNorm() < best_d) {
            best_d = d.squaredNorm();
            best = {i, j, k};
          }
        }
    return std::isfinite(best_d);
  };
  std::vector<long> position(grid.nodeCount(), -1);
  for (std::size_t l = 0; l < nodes.size(); ++l) position[nodes[l]] = static_cast<long>(l);
  BsplineExtension ext;
  std::vector<long> column(nodes.size(), -1);
  std::vector<char> outer(nodes.size(), 0);
  std::vector<Eigen::Vector3i> source(nodes.size());
  for (std::size_t l = 0; l < nodes.size(); ++l) {
    const Eigen::Vector3i v = nodeIjk(nodes[l]);
    if (!touchesInner(v) && nearestInner(v, source[l])) {
      // Extrapolate only from nodes that are unknowns themselves.
      bool all_known = true;
      for (int k = 0; k <= p && all_known; ++k)
        for (int j = 0; j <= p && all_known; ++j)
          for (int i = 0; i <= p && all_known; ++i)
            all_known = position[nodeId(source[l] + Eigen::Vector3i(i, j, k))] >= 0;
      outer[l] = all_known;
    }
    if (!outer[l]) {
      column[l] = static_cast<long>(ext.kept.size());
      ext.kept.push_back(static_cast<long>(l));
    }
  }
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t l = 0; l < nodes.size(); ++l) {
    if (!outer[l]) {
      entries.emplace_back(static_cast<int>(l), static_cast<int>(column[l]), 1.0);
      continue;
    }
    const Eigen::Vector3i v = nodeIjk(nodes[l]), c = source[l];
    for (int k = c(2); k <= c(2) + p; ++k)
      for (int j = c(1); j <= c(1) + p; ++j)
        for (int i = c(0); i <= c(0) + p; ++i) {
          const double w = lagrange(c(0), p, i, v(0)) * lagrange(c(1), p, j, v(1)) * lagrange(c(2), p, k, v(2));
          const long from = position[nodeId({i, j, k})];
          entries.emplace_back(static_cast<int>(l), static_cast<int>(column[from]), w);
        }
  }
  ext.map.resize(static_cast<long>(nodes.size()), static_cast<long>(ext.kept.size()));
  ext.map.setFromTriplets(entries.begin(), entries.end());
  return ext;
}

}  // namespace demnerf::mechanics
