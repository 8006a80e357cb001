#include "demnerf/mechanics/box_particles.hpp"

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

core::ParticleCloud makeBoxParticles(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                     const Eigen::Vector3i& cells) {
  if ((cells.array() < 1).any() || ((upper - lower).array() <= 0.0).any())
    throw core::Error("makeBoxParticles needs upper > lower and at least one cell per axis");
  const Eigen::Vector3d h = (upper - lower).cwiseQuotient(cells.cast<double>());
  core::ParticleCloud cloud;
  for (int k = 0; k < cells(2); ++k)
    for (int j = 0; j < cells(1); ++j)
      for (int i = 0; i < cells(0); ++i)
        cloud.append(lower + Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5).cwiseProduct(h), h.prod(), Eigen::Vector3d::Zero(), 0.0);
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const double area = h(u) * h(v);
    for (int side = 0; side < 2; ++side) {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n(axis) = side ? 1.0 : -1.0;
      for (int b = 0; b < cells(v); ++b)
        for (int a = 0; a < cells(u); ++a) {
          Eigen::Vector3d x;
          x(axis) = side ? upper(axis) : lower(axis);
          x(u) = lower(u) + (a + 0.5) * h(u);
          x(v) = lower(v) + (b + 0.5) * h(v);
          cloud.append(x, 0.0, n, area);
        }
    }
  }
  return cloud;
}

core::TriangleMesh boxSurface(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper) {
  core::TriangleMesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(k & 1 ? upper.x() : lower.x(), k & 2 ? upper.y() : lower.y(), k & 4 ? upper.z() : lower.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.push_back({q[0], q[1], q[2]});
    m.faces.push_back({q[0], q[2], q[3]});
  }
  return m;
}

}  // namespace demnerf::mechanics
