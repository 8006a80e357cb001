#pragma once
// From a trained NeRF to the simulation's inputs: its density on a grid, its surface mesh, and
// particle colours from its radiance. Shared by nerf_node and the demnerf CLI.

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/nerf/model.hpp"

namespace dem_nerf {

/// The model's density at the cell centres of a resolution^3 lattice over its scene box.
demnerf::geometry::DensityGrid densityGridOf(const demnerf::nerf::NerfModel& model, int resolution);

/// The closed surface where the density crosses config.threshold (largest component, repaired).
demnerf::geometry::MeshExtractionResult extractSurface(const demnerf::nerf::NerfModel& model, int resolution,
                                                       const demnerf::geometry::MeshExtractionConfig& config);

/// Colours each particle with the NeRF's radiance, seen from outside along its normal
/// (interior particles: from above).
void colourFromModel(const demnerf::nerf::NerfModel& model, demnerf::core::ParticleCloud* cloud);

}  // namespace dem_nerf
