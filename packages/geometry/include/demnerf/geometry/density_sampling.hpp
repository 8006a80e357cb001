#pragma once
// A density grid with cubic cells sampled from a batched density function (a NeRF's field).

#include <Eigen/Geometry>

#include "demnerf/geometry/density_grid.hpp"
#include "demnerf/geometry/density_inside_test.hpp"

namespace demnerf::geometry {

/// Samples `density` on a lattice of cubic cells over `box`: `resolution` cells along the box's
/// longest side, nodes at cell centres (as nerf::NerfModel::densityGrid), x fastest. Cubic
/// cells keep the surface error the same in every direction, where resolution^3 cells over a
/// flat box would be needlessly fine along its short side. Queries one z slice per call.
/// Throws core::Error for an empty or non-finite box or a resolution outside [2, 2048].
DensityGrid sampleDensityGrid(const DensityFunction& density, const Eigen::AlignedBox3d& box, int resolution);

}  // namespace demnerf::geometry
