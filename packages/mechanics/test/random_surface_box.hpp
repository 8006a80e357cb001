#pragma once
// A box whose surface particles lie at random on its faces, as a random sampler of a mesh places
// them (clumps and gaps), with interior particles on a lattice: for the tests of what the
// quadratures and loads make of a sampler's surface.

#include <Eigen/Core>
#include <cmath>
#include <random>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics::test {

// Surface particles at random on the box's faces (as a sampler of a mesh places them), coarse:
// about `spacing` apart, with interior particles on a lattice of that spacing.
inline core::ParticleCloud randomSurfaceBox(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper, double spacing,
                                            unsigned seed) {
  core::ParticleCloud out;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const Eigen::Vector3d size = upper - lower;
  const Eigen::Vector3i cells = (size / spacing).array().round().cast<int>();
  const Eigen::Vector3d cell = size.cwiseQuotient(cells.cast<double>());
  for (int k = 0; k < cells(2); ++k)
    for (int j = 0; j < cells(1); ++j)
      for (int i = 0; i < cells(0); ++i)
        out.append(lower + cell.cwiseProduct(Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5)), cell.prod(),
                    Eigen::Vector3d::Zero(), 0.0);
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      const double area = size(a) * size(b);
      const int n = static_cast<int>(std::round(area / (spacing * spacing)));
      for (int p = 0; p < n; ++p) {
        Eigen::Vector3d x = lower;
        x(axis) = side ? upper(axis) : lower(axis);
        x(a) += size(a) * u01(rng);
        x(b) += size(b) * u01(rng);
        out.append(x, 0.0, (side ? 1.0 : -1.0) * Eigen::Vector3d::Unit(axis), area / n);
      }
    }
  return out;
}

}  // namespace demnerf::mechanics::test
