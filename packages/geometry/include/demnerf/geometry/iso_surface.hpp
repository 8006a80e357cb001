#pragma once
// Iso-surface extraction from a density grid.

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_grid.hpp"

namespace demnerf::geometry {

/// The surface {density = threshold} as a closed triangle mesh with outward faces (normals
/// point from density > threshold to density <= threshold). Marching tetrahedra: each grid
/// cell is split into six tetrahedra around its main diagonal, which has no ambiguous cases,
/// so the result is watertight and manifold. Outside the grid counts as empty space, so the
/// surface closes where the body touches the grid's border. Vertices are shared between
/// faces. Empty when no value exceeds the threshold.
core::TriangleMesh extractIsoSurface(const DensityGrid& grid, double threshold);

}  // namespace demnerf::geometry
