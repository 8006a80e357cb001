#include "demnerf/geometry/mesh_repair.hpp"

#include <algorithm>

namespace demnerf::geometry {

core::TriangleMesh smoothMesh(const core::TriangleMesh& mesh, const SmoothingConfig& config) {
  const std::size_t n = mesh.vertices.size();
  std::vector<std::vector<int>> neighbours(n);
  for (const auto& face : mesh.faces) {
    for (int c = 0; c < 3; ++c) {
      neighbours[face[c]].push_back(face[(c + 1) % 3]);
      neighbours[face[c]].push_back(face[(c + 2) % 3]);
    }
  }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  core::TriangleMesh result = mesh;
  std::vector<Eigen::Vector3d> next(n);
  // Taubin: a shrinking Laplacian step (lambda) then an inflating one (mu), a low-pass filter
  // that removes the marching-cubes staircase without the shrinkage of plain Laplacian smoothing.
  auto step = [&](double factor) {
    for (std::size_t v = 0; v < n; ++v) {
      next[v] = result.vertices[v];
      if (neighbours[v].empty()) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int u : neighbours[v]) mean += result.vertices[u];
      mean /= static_cast<double>(neighbours[v].size());
      next[v] += factor * (mean - result.vertices[v]);
    }
    result.vertices.swap(next);
  };
  for (int i = 0; i < config.iterations; ++i) {
    step(config.lambda);
    step(config.mu);
  }
  return result;
}

}  // namespace demnerf::geometry
