#pragma once
// A fill-reducing order of a mesh's node graph for the FEM's sparse Cholesky
// (FemConfig::Ordering::kNestedDissection). Private to packages/mechanics/src.

#include <Eigen/Core>
#include <vector>

namespace demnerf::mechanics {

/// The nodes in elimination order; adj_start/adj is the graph in compressed rows (the neighbours
/// of node i are adj[adj_start[i] .. adj_start[i + 1])).
std::vector<int> nestedDissection(const std::vector<Eigen::Vector3d>& x, const std::vector<int>& adj_start,
                                  const std::vector<int>& adj);

}  // namespace demnerf::mechanics
