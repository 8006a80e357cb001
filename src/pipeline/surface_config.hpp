#pragma once
// How a trained NeRF becomes the closed surface the particles fill: the one configuration of
// `demnerf extract`, `demnerf sample --model` and nerf_node's ~extraction namespace. No torch here,
// so that node configs can include it.

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"

namespace dem_nerf {

struct SurfaceConfig {
  /// Cubic cells along the longest side of the model's box (or of `box`). 192 is 2 mm on the
  /// T-bar: volume within 1 % and ~340k faces in ~3 s; 256 alone is slower (~630k faces), no
  /// truer. With a closing (mesh.solid.radius 8 mm) 320 cells give a truer NeRF T-bar (Chamfer
  /// ~1.07 -> 0.81 mm, area +8 -> +1.5 %): docs/mechanics_matrix_nerf.md, "Extraction settings".
  int resolution = 192;
  /// The surface: where the body reaches opacity 0.15 seen from outside (on the T-bar the volume
  /// within 3 %, where instant-ngp's density 2.5 gives +16 %), or a density level.
  demnerf::geometry::MeshExtractionConfig mesh = renderedSurface();
  /// A box in the scene's frame around one object of a real capture: only its largest piece is
  /// meshed, closed at the box's faces (unset: the whole model box, for isolated objects).
  std::optional<Eigen::AlignedBox3d> box;
  demnerf::geometry::IsolationConfig isolation;
  /// Space carving against the capture's training cameras: 0 off; N >= 1 fills what fewer than N
  /// of them saw in plain view as empty (1: the visual hull; the fox takes 4, so its thin ears keep
  /// a back). Needs mesh.solid.radius > 0, which shuts the slits grazing views leave, and excludes
  /// mesh.solid.behind. The cameras come from whoever trained the model (withTrainingCameras):
  /// `demnerf extract --solid-cameras DIR` the dataset's training split, nerf_node its keyframes.
  /// It only fills: on a body seen all round (the synthetic T-bar's 48 views) it adds nothing to
  /// the closing, and it cannot cut a NeRF's outward bumps.
  int solid_views = 0;

  static demnerf::geometry::MeshExtractionConfig renderedSurface() {
    demnerf::geometry::MeshExtractionConfig mesh;
    mesh.surface = demnerf::geometry::SurfaceDefinition::kOpacity;
    mesh.opacity = 0.15;
    mesh.simplification.fast = true;  // a face budget, when set, collapses shortest edges first
    // No Taubin passes (mesh.repair.smoothing_iterations 0): on the NeRF T-bar and cuboid, 2-100
    // passes move the Chamfer distance to the true body by under 0.04 mm and leave the bumps the
    // DEM finds stiff (their wavelengths pass the filter); docs/mechanics_matrix_nerf.md,
    // "A smoothed extraction".
    return mesh;
  }
};

/// The settings in YAML text over `base`; keys: resolution, surface (opacity | density), opacity,
/// threshold, max_faces, smoothing, box ([xmin, ymin, zmin, xmax, ymax, zmax]), max_second_piece,
/// solid_radius (>= 0, the scene's units), solid_behind ([dx, dy, dz] towards the cameras),
/// solid_views (>= 0; > 0 needs solid_radius > 0 and no solid_behind). Throws core::Error naming
/// `source` and the key for unknown keys, wrong types, values out of range and such pairs.
SurfaceConfig parseSurfaceConfig(const std::string& yaml_text, const std::string& source, SurfaceConfig base = {});

/// `config` with the cameras its space carving needs: for solid_views > 0, mesh.solid.cameras
/// gets the intrinsics and poses of `frames` (the ones the model trained on, in its scene frame)
/// and mesh.solid.min_views solid_views; for 0, config as it is. `origin` names the frames in
/// the errors: core::Error when there are none, or fewer than solid_views (no node could then
/// count as seen empty, and the carving would fill the whole box).
SurfaceConfig withTrainingCameras(SurfaceConfig config, const std::vector<demnerf::core::Frame>& frames,
                                  const std::string& origin);

}  // namespace dem_nerf
