#include "demnerf/mechanics/particle_quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace demnerf::mechanics {
namespace {

// Uniform hash grid over the interior particles for nearest-neighbour queries.
struct Grid {
  double cell;
  Eigen::Vector3d lower;
  std::unordered_map<long long, std::vector<int>> cells;
  long long key(const Eigen::Vector3i& c) const {
    return (static_cast<long long>(c(0)) * 73856093LL) ^ (static_cast<long long>(c(1)) * 19349663LL) ^
           (static_cast<long long>(c(2)) * 83492791LL);
  }
  Eigen::Vector3i index(const Eigen::Vector3d& x) const {
    return ((x - lower) / cell).array().floor().cast<int>();
  }
};

}  // namespace

std::vector<double> energyWeights(const core::ParticleCloud& cloud) {
  std::vector<double> w = cloud.volumes;
  std::vector<int> interior;
  double volume = 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.volumes[i] > 0) {
      interior.push_back(static_cast<int>(i));
      volume += cloud.volumes[i];
      lo = lo.cwiseMin(cloud.positions[i]);
      hi = hi.cwiseMax(cloud.positions[i]);
    }
  if (interior.empty()) return w;
  Grid grid;
  grid.lower = lo;
  grid.cell = std::max(std::cbrt(volume / interior.size()) * 2.0, 1e-12);
  for (int i : interior) grid.cells[grid.key(grid.index(cloud.positions[i]))].push_back(i);
  std::vector<int> donor(cloud.size(), -1);
  std::vector<double> request(cloud.size(), 0.0), asked(cloud.size(), 0.0);
  for (std::size_t s = 0; s < cloud.size(); ++s) {
    if (!cloud.isSurface(s) || cloud.volumes[s] > 0) continue;
    const Eigen::Vector3i c = grid.index(cloud.positions[s]);
    int best = -1;
    double best_d = 1e300;
    for (int ring = 1; ring <= 3 && best < 0; ++ring)
      for (int z = -ring; z <= ring; ++z)
        for (int y = -ring; y <= ring; ++y)
          for (int x = -ring; x <= ring; ++x) {
            auto it = grid.cells.find(grid.key(c + Eigen::Vector3i(x, y, z)));
            if (it == grid.cells.end()) continue;
            for (int i : it->second) {
              const double d = (cloud.positions[i] - cloud.positions[s]).squaredNorm();
              if (d < best_d) {
                best_d = d;
                best = i;
              }
            }
          }
    if (best < 0) continue;
    const double depth = std::abs((cloud.positions[best] - cloud.positions[s]).dot(cloud.normals[s]));
    donor[s] = best;
    request[s] = 0.5 * cloud.areas[s] * depth;
    asked[best] += request[s];
  }
  // A donor gives at most half its volume, so interior weights stay positive.
  for (std::size_t s = 0; s < cloud.size(); ++s) {
    if (donor[s] < 0) continue;
    const int d = donor[s];
    const double factor = std::min(1.0, 0.5 * cloud.volumes[d] / asked[d]);
    w[s] += factor * request[s];
  }
  for (std::size_t s = 0; s < cloud.size(); ++s) {
    if (donor[s] < 0) continue;
    const int d = donor[s];
    const double factor = std::min(1.0, 0.5 * cloud.volumes[d] / asked[d]);
    w[d] -= factor * request[s];
  }
  return w;
}

}  // namespace demnerf::mechanics
