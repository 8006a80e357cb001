#pragma once
// The rows A of the Gauss-Newton metric G = A^T A of the MLP-only DEM (dem_gauss_newton.cpp): per
// drawn point the Jacobians, in the network's parameters, of the Green strain weighed by the
// material's tangent. Autograd built them from per-point copies of the weights and ~6 backward
// passes through batched 30 x 30 products: 0.46 s a step on the NeRF T-bar (500 points, 2,073
// parameters), half the step. Here each point runs forward once and backward once per row by hand,
// in double: ~0.01-0.02 s a step (docs/dem_feature_grid.md, "A faster Gauss-Newton step").
// Private to packages/mechanics/src. No Eigen or torch types: built like mlp_energy_kernel.cpp.

#include <cstdint>

#include "mlp_energy_kernel.hpp"

namespace demnerf::mechanics::strain_rows {

/// The metric's constants. The rows are the Jacobians of sqrt(w / energy_scale) times:
/// current: L^T mandel(E), L L^T the compressible Neo-Hookean's tangent dS/dE at the point's strain
/// in Mandel form (its shear factor mu - lambda ln J kept above mu / 10), six rows; else
/// sqrt(lambda) tr E and sqrt(2 mu) E_ij (i <= j, off-diagonals x sqrt 2), seven rows.
struct Metric {
  double mu = 0.0, lambda = 0.0;
  double load_scale = 1.0, output_scale = 1.0, energy_scale = 1.0;
  bool current = false;
};

/// Rows per point: 6 (current) or 7.
int rowsPerPoint(const Metric& metric);

/// The parameters' count, in the order weights then bias, layer by layer (the columns of A).
std::int64_t parameterCount(const mlp_kernel::Network& net);

/// Writes A (rows x parameterCount, row-major, float) for the points (x, weight and the exact
/// boundary's lift g, grad_g, D, grad_D; body is not read). Row order as the autograd rows had
/// it: point by point (q * 6 + r) for the current tangent, row kind by row kind (r * n + q) else.
/// `threads` > 1 splits the points into contiguous ranges.
void strainJacobianRows(const mlp_kernel::Network& net, const Metric& metric, const mlp_kernel::VolumePoints& points,
                        float* rows, int threads);

}  // namespace demnerf::mechanics::strain_rows
