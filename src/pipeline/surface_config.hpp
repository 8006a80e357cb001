#pragma once
// How a trained NeRF becomes the closed surface the particles fill: the one configuration of
// `demnerf extract`, `demnerf sample --model` and nerf_node's ~extraction namespace. No torch here,
// so that node configs can include it.

#include <Eigen/Geometry>

#include <optional>
#include <string>

#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"

namespace dem_nerf {

struct SurfaceConfig {
  /// Cubic cells along the longest side of the model's box (or of `box`). 192 is 2 mm on the
  /// T-bar: volume within 1 % and ~340k faces in ~3 s; 256 is slower (~630k faces), no better.
  int resolution = 192;
  /// The surface: where the body reaches opacity 0.15 seen from outside (on the T-bar the volume
  /// within 3 %, where instant-ngp's density 2.5 gives +16 %), or a density level.
  demnerf::geometry::MeshExtractionConfig mesh = renderedSurface();
  /// A box in the scene's frame around one object of a real capture: only its largest piece is
  /// meshed, closed at the box's faces (unset: the whole model box, for isolated objects).
  std::optional<Eigen::AlignedBox3d> box;
  demnerf::geometry::IsolationConfig isolation;

  static demnerf::geometry::MeshExtractionConfig renderedSurface() {
    demnerf::geometry::MeshExtractionConfig mesh;
    mesh.surface = demnerf::geometry::SurfaceDefinition::kOpacity;
    mesh.opacity = 0.15;
    mesh.simplification.fast = true;  // a face budget, when set, collapses shortest edges first
    return mesh;
  }
};

/// The settings in YAML text over `base`; keys: resolution, surface (opacity | density), opacity,
/// threshold, max_faces, smoothing, box ([xmin, ymin, zmin, xmax, ymax, zmax]), max_second_piece,
/// solid_radius (>= 0, the scene's units), solid_behind ([dx, dy, dz] towards the cameras).
/// Throws core::Error naming `source` and the key for unknown keys, wrong types and values out of
/// range.
SurfaceConfig parseSurfaceConfig(const std::string& yaml_text, const std::string& source, SurfaceConfig base = {});

}  // namespace dem_nerf
