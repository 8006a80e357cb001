#pragma once
// The output-amplitude line search of the network solvers (dem_solver, pinn_solver). The a-priori
// displacement scale (load / stiffness x size) can be 100x off for slender bodies (torsion), and
// Adam cannot grow an output layer 100x in a few hundred steps; one parabola fit per call can.

#include <algorithm>
#include <cmath>
#include <optional>

namespace demnerf::mechanics {

/// The factor alpha that minimises a loss nearly quadratic in the network's output amplitude:
/// `loss(alpha)` is the loss with the amplitude times alpha (NaN where particles invert). The
/// parabola goes through alpha = 0, 1, 2, or 0, 0.5, 1 when 2 inverts; a loss not convex in
/// alpha grows the amplitude the most allowed (unless 2 already inverts). The factor is clamped to
/// [0.1, 10] per call, so a badly guessed scale is corrected within a few calls; nothing when the
/// losses are not finite or the fit gives no positive factor.
template <typename Loss>
std::optional<double> fitAmplitude(Loss&& loss) {
  const double l0 = loss(0.0), l1 = loss(1.0);
  double h = 1.0, lh = l1, l2 = loss(2.0);
  if (!std::isfinite(l2)) {
    h = 0.5;
    l2 = l1;
    lh = loss(0.5);
  }
  if (!std::isfinite(l0) || !std::isfinite(lh) || !std::isfinite(l2)) return std::nullopt;
  // Parabola through (0, l0), (h, lh), (2h, l2).
  const double c2 = (l2 - 2 * lh + l0) / (2 * h * h), c1 = (lh - l0) / h - c2 * h;
  double alpha = c2 > 0 ? -c1 / (2 * c2) : h == 1.0 ? 10.0 : std::nan("");
  if (!std::isfinite(alpha) || alpha <= 0) return std::nullopt;
  return std::clamp(alpha, 0.1, 10.0);
}

}  // namespace demnerf::mechanics
