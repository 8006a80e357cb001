#pragma once
// The NeRF surface extraction's defaults, in a header without torch so that node configs can
// include it.

namespace dem_nerf {

/// The surface the pipeline extracts unless told otherwise, for `demnerf extract`, `demnerf
/// sample --model` and nerf_node (~extract_resolution, ~surface_opacity) alike: where the body
/// reaches opacity 0.15 seen from outside (on the T-bar the volume within 3 %, where instant-ngp's
/// density 2.5 gives +16 %), on 192 cubic cells along the longest side (2 mm on the T-bar: volume
/// within 1 % and ~340k faces in ~3 s; 256 is slower, ~630k faces, no better volume).
struct SurfaceDefaults {
  int resolution = 192;
  double opacity = 0.15;
};

}  // namespace dem_nerf
