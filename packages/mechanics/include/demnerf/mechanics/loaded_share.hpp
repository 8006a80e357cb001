#pragma once
// How much of a surface particle's area a load region covers. A particle stands for a patch of the
// surface about sqrt(area) wide; counting it wholly in or out of a region moves the loaded patch's
// edge by up to half a spacing, and with it the patch's area and centroid: on the T-bar twist the
// couple's arm moved by up to 1 % (a lattice cloud whose rows fall just inside the region's edge),
// 2 % of the energy, for the same body and load. Clipping each particle's patch to the region makes
// the loaded area and its centroid follow the region, not the sampler.

#include <Eigen/Core>

#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

/// The part (0..1) of a surface particle's area inside the region: the area as a square of side
/// sqrt(area) in the particle's tangent plane (sides along the tangents nearest the coordinate
/// axes), clipped to the region on an 8 x 8 lattice of sub-points.
/// Regions are convex, so a square whose corners are all inside is wholly inside. A particle
/// without a unit normal counts wholly in or out by its position.
double loadedShare(const core::Region& region, const Eigen::Vector3d& position, const Eigen::Vector3d& normal,
                   double area);

}  // namespace demnerf::mechanics
