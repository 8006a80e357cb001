#pragma once
// How rough a cloud's surface is at the feature grid's scale (dem_config_check.cpp sizes the grid
// finer on a rough one). Private to packages/mechanics/src.
//
// Why: a surface extracted from a NeRF carries bumps of a few mm. Torsion's shear is largest at
// the surface, and 10 mm quadratic B-splines cannot follow it there: the NeRF rows' energies were
// 1-2 % stiff where the exact surfaces' were within 1 %, and the error fell about linearly with
// the cell (docs/dem_feature_grid.md, "The NeRF rows' energy").

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

/// The surface particles' scatter about their local quadric at scale `radius` (m): per sampled
/// surface particle (at most 4,000, evenly strided), the RMS distance of the surface particles
/// within `radius` whose normals turn less than 30 degrees from its own (the other faces at an edge
/// are not roughness) from their least-squares quadric height field, taken where at least ten are
/// found; the median over those particles. 0 on the flat faces of an exactly sampled mesh, ~0 on a
/// smooth curve, and 0 when no particle has the neighbours.
double surfaceRoughness(const core::ParticleCloud& cloud, double radius);

/// The surface particles' spacing: the square root of their median area (0 without any).
double surfaceParticleSpacing(const core::ParticleCloud& cloud);

}  // namespace demnerf::mechanics
