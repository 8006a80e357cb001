#pragma once
// Density grid -> closed surface mesh: iso-surface, largest component, holes, orientation.

#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_grid.hpp"
#include "demnerf/geometry/mesh_repair.hpp"
#include "demnerf/geometry/mesh_simplification.hpp"
#include "demnerf/geometry/solid_body.hpp"

namespace demnerf::geometry {

/// What "the surface" of a density field is.
enum class SurfaceDefinition {
  kDensity,  ///< {sigma = threshold}: instant-ngp's marching cubes (threshold 2.5)
  kOpacity,  ///< where a view from outside along the clearest axis reaches `opacity` (axisOpticalDepth)
};

struct MeshExtractionConfig {
  SurfaceDefinition surface = SurfaceDefinition::kDensity;
  /// kDensity: density at the surface. 2.5 is instant-ngp's default for its marching cubes; see
  /// densityForOpacity() for a threshold chosen from an opacity per step.
  double threshold = 2.5;
  /// kOpacity: opacity at the surface, in (0, 1); 0.5 is where a rendered ray's depth lands.
  double opacity = 0.5;
  /// The inside made solid before the surface is taken (solidifyField): a closing that shuts
  /// tunnels, a fill of what the body hides from a one-sided capture's cameras, and cavities
  /// sealed off from outside filled. Off by default, which is right for synthetic bodies whose
  /// density is solid; a real capture's is a shell with tunnels (the fox's head: genus ~450 at
  /// density 20, open at the back the cameras never saw), see docs/nerf_real_captures.md.
  SolidConfig solid;
  MeshRepairConfig repair;
  /// Edge-collapse budget applied after repair (0 keeps every marching-tetrahedra face).
  MeshSimplificationConfig simplification{0};
};

struct MeshExtractionResult {
  core::TriangleMesh mesh;
  std::size_t vertices = 0;
  std::size_t faces = 0;
  double volume = 0.0;
  double area = 0.0;
  bool closed = false;
  MeshRepairReport repair;
  MeshSimplificationReport simplification;
  double iso_value = 0.0;  ///< the level extracted: the density threshold, or -ln(1 - opacity)
  SolidReport solid;       ///< what the solid config filled (zeros when it is off)
  SurfaceTopology topology;  ///< of the final mesh: components, Euler characteristic, genus
};

/// Parses "density" | "opacity" (the CLI's --surface); throws core::Error naming the value.
SurfaceDefinition parseSurfaceDefinition(const std::string& name);

/// Extracts, repairs and (with a face budget) simplifies the surface. Throws core::Error
/// naming the threshold (or opacity) and the grid's range when no cell crosses it.
MeshExtractionResult extractMesh(const DensityGrid& grid, const MeshExtractionConfig& config = {});

}  // namespace demnerf::geometry
