#pragma once
// From a trained NeRF to the simulation's inputs: its density on a grid, its surface mesh, and
// particle colours from its radiance. Shared by nerf_node and the demnerf CLI.

#include "demnerf/core/particle_cloud.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/nerf/model.hpp"
#include "pipeline/surface_config.hpp"

namespace dem_nerf {

/// The model's density on cubic cells over its scene box, `resolution` along the longest side.
demnerf::geometry::DensityGrid densityGridOf(const demnerf::nerf::NerfModel& model, int resolution);

/// The model's density on cubic cells over `box` (the scene's frame), closed at the box's faces:
/// the input of geometry::isolateObject for one object of a real capture.
demnerf::geometry::DensityGrid densityGridInBox(const demnerf::nerf::NerfModel& model, const Eigen::AlignedBox3d& box,
                                                int resolution);

/// The closed surface of the model (config says which: density level or opacity from outside),
/// over the model's box, or of the largest piece inside config.box (geometry::isolateObject's
/// refusals: box empty, several comparable pieces, surface open). `pieces` gets the box's pieces.
demnerf::geometry::MeshExtractionResult extractSurface(const demnerf::nerf::NerfModel& model,
                                                       const SurfaceConfig& config,
                                                       demnerf::geometry::IsolationReport* pieces = nullptr);

/// Colours each particle with the NeRF's radiance, seen from outside along its normal
/// (interior particles: from above).
void colourFromModel(const demnerf::nerf::NerfModel& model, demnerf::core::ParticleCloud* cloud);

/// The model's surface (extractSurface) filled with coloured particles. A sampling spacing <= 0
/// means 1/40 of the mesh's bounding-box diagonal (a few thousand particles for any body size).
/// The mesh is handed back through mesh_out when given (nerf_node draws it).
demnerf::core::ParticleCloud particlesFromModel(const demnerf::nerf::NerfModel& model, const SurfaceConfig& surface,
                                                demnerf::geometry::SamplerConfig sampling,
                                                demnerf::core::TriangleMesh* mesh_out = nullptr);

}  // namespace dem_nerf
