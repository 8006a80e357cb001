#pragma once
// Surfaces by opacity: how much density a view from outside crosses before reaching a point.

#include "demnerf/geometry/density_grid.hpp"

namespace demnerf::geometry {

/// For every node, the optical depth tau = integral of sigma ds (trapezoid rule, outside the
/// grid sigma = 0) from the grid's border to the node along each of the six axis directions,
/// and the smallest of the six. exp(-tau) is what an orthographic camera looking along the
/// clearest axis still sees of the node, so {tau = -ln(1 - alpha)} is where such a view
/// reaches opacity alpha: the surface as rendered. Unlike a density iso-surface it ignores
/// what the NeRF put inside the body (never seen, often low or noisy: cavities, tunnels),
/// and it needs no density scale. Concavities no axis-aligned line can reach are filled.
DensityGrid axisOpticalDepth(const DensityGrid& density);

}  // namespace demnerf::geometry
