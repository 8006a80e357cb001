// The FEM tangent's sparsity, fixed once per mesh: elements coloured so that no two of a colour
// share a node (parallel assembly without locks), nodes ordered for the factorisation, free dofs
// numbered node by node in that order, the lower triangle's column pattern, and for every
// element's local dof pair the position of its entry in K.
#include <algorithm>

#include "fem_solver_impl.hpp"
#include "fill_reducing_order.hpp"
#include "parallel_for.hpp"

namespace demnerf::mechanics {
namespace {

/// Compressed rows: the entries of row i are list[start[i] .. start[i + 1]).
struct Csr {
  std::vector<int> start, list;
};

/// Node -> the elements that hold it.
Csr nodeElements(const TetMesh& mesh, int n) {
  const int n_nodes = static_cast<int>(mesh.nodes.size());
  const int n_el = static_cast<int>(mesh.elements.size());
  Csr out;
  out.start.assign(n_nodes + 1, 0);
  out.list.resize(static_cast<std::size_t>(n_el) * n);
  for (const auto& el : mesh.elements)
    for (int a = 0; a < n; ++a) ++out.start[el[a] + 1];
  for (int i = 0; i < n_nodes; ++i) out.start[i + 1] += out.start[i];
  std::vector<int> fill(out.start.begin(), out.start.end() - 1);
  for (int e = 0; e < n_el; ++e)
    for (int a = 0; a < n; ++a) out.list[fill[mesh.elements[e][a]]++] = e;
  return out;
}

/// Greedy colouring: an element takes the first colour none of its node neighbours has.
std::vector<std::vector<int>> colourElements(const TetMesh& mesh, int n, const Csr& elements_of) {
  const int n_el = static_cast<int>(mesh.elements.size());
  std::vector<std::vector<int>> colours;
  std::vector<int> colour(n_el, -1), stamp;
  for (int e = 0; e < n_el; ++e) {
    for (int a = 0; a < n; ++a) {
      const int node = mesh.elements[e][a];
      for (int k = elements_of.start[node]; k < elements_of.start[node + 1]; ++k) {
        const int c = colour[elements_of.list[k]];
        if (c < 0) continue;
        if (c >= static_cast<int>(stamp.size())) stamp.resize(c + 1, -1);
        stamp[c] = e;
      }
    }
    int c = 0;
    while (c < static_cast<int>(stamp.size()) && stamp[c] == e) ++c;
    colour[e] = c;
    if (c >= static_cast<int>(colours.size())) colours.resize(c + 1);
    colours[c].push_back(e);
  }
  return colours;
}

/// Node adjacency through shared elements, each row sorted, the node itself included.
Csr nodeAdjacency(const TetMesh& mesh, int n, const Csr& elements_of) {
  const int n_nodes = static_cast<int>(mesh.nodes.size());
  Csr adj;
  adj.start.assign(n_nodes + 1, 0);
  std::vector<int> mark(n_nodes, -1), neighbours;
  for (int node = 0; node < n_nodes; ++node) {
    neighbours.clear();
    for (int k = elements_of.start[node]; k < elements_of.start[node + 1]; ++k)
      for (int a = 0; a < n; ++a) {
        const int other = mesh.elements[elements_of.list[k]][a];
        if (mark[other] != node) {
          mark[other] = node;
          neighbours.push_back(other);
        }
      }
    std::sort(neighbours.begin(), neighbours.end());
    adj.list.insert(adj.list.end(), neighbours.begin(), neighbours.end());
    adj.start[node + 1] = static_cast<int>(adj.list.size());
  }
  return adj;
}

/// Column pattern (outer starts, inner rows) of the free-free tangent's lower triangle: rows of a
/// column come out sorted when the neighbour nodes are visited in increasing rank.
Csr lowerPattern(const std::vector<int>& order, const Csr& adj, const std::vector<int>& free_index, int n_free) {
  std::vector<int> rank(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) rank[order[i]] = static_cast<int>(i);
  Csr pattern;
  pattern.start.assign(n_free + 1, 0);
  std::vector<int> neighbours;
  for (int node : order) {
    neighbours.clear();
    for (int k = adj.start[node]; k < adj.start[node + 1]; ++k)
      if (rank[adj.list[k]] >= rank[node]) neighbours.push_back(adj.list[k]);
    std::sort(neighbours.begin(), neighbours.end(), [&](int x, int y) { return rank[x] < rank[y]; });
    for (int c = 0; c < 3; ++c) {
      const int col = free_index[3 * node + c];
      if (col < 0) continue;
      for (int other : neighbours)
        for (int r = 0; r < 3; ++r) {
          const int row = free_index[3 * other + r];
          if (row >= col) pattern.list.push_back(row);
        }
      pattern.start[col + 1] = static_cast<int>(pattern.list.size());
    }
  }
  return pattern;
}

}  // namespace

void FemSolver::Impl::setupPattern() {
  const int n_nodes = static_cast<int>(mesh.nodes.size());
  const int n_el = static_cast<int>(mesh.elements.size());
  const Csr elements_of = nodeElements(mesh, n);
  colours = colourElements(mesh, n, elements_of);
  const Csr adj = nodeAdjacency(mesh, n, elements_of);
  // Node order for the factorisation, then free dofs numbered node by node in that order.
  std::vector<int> order;
  if (config.ordering == FemConfig::Ordering::kNestedDissection) {
    order = nestedDissection(mesh.nodes, adj.start, adj.list);
  } else {
    order.resize(n_nodes);
    for (int i = 0; i < n_nodes; ++i) order[i] = i;
  }
  n_free = 0;
  for (int node : order)
    for (int c = 0; c < 3; ++c)
      if (free_index[3 * node + c] >= 0) free_index[3 * node + c] = n_free++;
  const Csr pattern = lowerPattern(order, adj, free_index, n_free);
  K.resize(n_free, n_free);
  K.resizeNonZeros(static_cast<Eigen::Index>(pattern.list.size()));
  std::copy(pattern.start.begin(), pattern.start.end(), K.outerIndexPtr());
  std::copy(pattern.list.begin(), pattern.list.end(), K.innerIndexPtr());
  std::fill(K.valuePtr(), K.valuePtr() + pattern.list.size(), 0.0);
  // Scatter positions: where each element's packed local pair lands in K's values.
  const int m = 3 * n, packed = m * (m + 1) / 2;
  scatter.assign(static_cast<std::size_t>(n_el) * packed, -1);
  parallelFor(n_el, threads, [&](long begin, long end) {
    for (int e = begin; e < end; ++e)
      for (int r = 0; r < m; ++r) {
        const int fr = free_index[3 * mesh.elements[e][r / 3] + r % 3];
        if (fr < 0) continue;
        for (int c = 0; c <= r; ++c) {
          const int fc = free_index[3 * mesh.elements[e][c / 3] + c % 3];
          if (fc < 0) continue;
          const int row = std::max(fr, fc), col = std::min(fr, fc);
          const int* first = K.innerIndexPtr() + K.outerIndexPtr()[col];
          const int* last = K.innerIndexPtr() + K.outerIndexPtr()[col + 1];
          scatter[static_cast<std::size_t>(e) * packed + r * (r + 1) / 2 + c] =
              static_cast<int>(std::lower_bound(first, last, row) - K.innerIndexPtr());
        }
      }
  });
}

}  // namespace demnerf::mechanics
