#include "fill_reducing_order.hpp"

#include <algorithm>

namespace demnerf::mechanics {
namespace {

// Nested dissection of the node graph by coordinate bisection: split the nodes at the median
// coordinate of their longest axis, take as separator the smaller of the two sets of nodes that
// touch the other side, order both halves recursively and the separator last. (On the T-bar
// meshes tried it gave more fill than AMD; see FemConfig::ordering.)
void dissect(std::vector<int>& nodes, int begin, int end, const std::vector<Eigen::Vector3d>& x,
             const std::vector<int>& adj_start, const std::vector<int>& adj, std::vector<int>& side,
             std::vector<int>& out) {
  const int count = end - begin;
  if (count <= 96) {
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  // Try the median split along each axis and keep the one with the smallest separator (bodies
  // like a T-bar are badly split along the longest axis of their bounding box).
  std::vector<int> best_sep;
  int best_axis = -1;
  double best_split = 0;
  std::vector<double> coord(count);
  for (int axis = 0; axis < 3; ++axis) {
    for (int i = 0; i < count; ++i) coord[i] = x[nodes[begin + i]](axis);
    std::nth_element(coord.begin(), coord.begin() + count / 2, coord.end());
    const double split = coord[count / 2];
    // Side 1: below the split, 2: at or above it; 0 marks nodes outside this subset.
    int below = 0;
    for (int i = begin; i < end; ++i) {
      side[nodes[i]] = x[nodes[i]](axis) < split ? 1 : 2;
      below += side[nodes[i]] == 1;
    }
    std::vector<int> touch[3];
    if (below > 0 && below < count)
      for (int i = begin; i < end; ++i) {
        const int v = nodes[i], s = side[v];
        for (int k = adj_start[v]; k < adj_start[v + 1]; ++k)
          if (side[adj[k]] != 0 && side[adj[k]] != s) {
            touch[s].push_back(v);
            break;
          }
      }
    for (int i = begin; i < end; ++i) side[nodes[i]] = 0;
    if (below == 0 || below == count) continue;
    const int sep_side = touch[1].size() <= touch[2].size() ? 1 : 2;
    if (best_axis < 0 || touch[sep_side].size() < best_sep.size()) {
      best_axis = axis;
      best_split = split;
      best_sep = touch[sep_side];
    }
  }
  if (best_axis < 0) {  // all nodes on one point: nothing to split
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  for (int i = begin; i < end; ++i) side[nodes[i]] = x[nodes[i]](best_axis) < best_split ? 1 : 2;
  for (int v : best_sep) side[v] = 3;
  std::vector<int> part[4];
  for (int i = begin; i < end; ++i) part[side[nodes[i]]].push_back(nodes[i]);
  for (int i = begin; i < end; ++i) side[nodes[i]] = 0;
  if (part[1].empty() || part[2].empty()) {  // no progress (all on one coordinate): stop here
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  int pos = begin;
  const int b1 = pos;
  for (int v : part[1]) nodes[pos++] = v;
  const int b2 = pos;
  for (int v : part[2]) nodes[pos++] = v;
  const int b3 = pos;
  for (int v : part[3]) nodes[pos++] = v;
  dissect(nodes, b1, b2, x, adj_start, adj, side, out);
  dissect(nodes, b2, b3, x, adj_start, adj, side, out);
  out.insert(out.end(), part[3].begin(), part[3].end());
}

}  // namespace

std::vector<int> nestedDissection(const std::vector<Eigen::Vector3d>& x, const std::vector<int>& adj_start,
                                  const std::vector<int>& adj) {
  const int n_nodes = static_cast<int>(x.size());
  std::vector<int> nodes(n_nodes), side(n_nodes, 0), out;
  for (int i = 0; i < n_nodes; ++i) nodes[i] = i;
  out.reserve(n_nodes);
  dissect(nodes, 0, n_nodes, x, adj_start, adj, side, out);
  return out;
}


}  // namespace demnerf::mechanics
