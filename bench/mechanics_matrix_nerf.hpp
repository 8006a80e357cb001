#pragma once
// The solver matrix's NeRF source: the surface a user gets from `demnerf synth`, `demnerf train`
// and `demnerf extract` on a synthetic scene, cached so reruns skip the training.

#include <string>

#include "demnerf/core/ply.hpp"

namespace demnerf::bench {

struct NerfSurfaceConfig {
  std::string scene;       ///< tbar | cuboid (render::SynthConfig::scene)
  std::string work_dir;    ///< views, model and the cached mesh (created if absent)
  double seconds = 60.0;   ///< NeRF training time, as `demnerf train --seconds`
  double cpu_seconds = 0;  ///< > 0: a budget of CPU seconds instead (2 x seconds on an idle 2-core
                           ///< machine; what a machine shared with other work inflates least)
  std::string nerf_config; ///< a NeRF YAML over the defaults (e.g. `train: {seed: 2}`: another draw); empty: defaults
  int resolution = 192;    ///< density cells along the longest side, `demnerf extract`'s default
  int max_faces = 20000;   ///< edge-collapse budget: the CGAL reference meshes stay quick
};

/// WORK_DIR/extracted_mesh.ply when it exists; otherwise synthesises the scene's views (48, 200 px),
/// trains the NeRF for `seconds` (kept as WORK_DIR/model.nerf, to extract again), extracts the
/// opacity-0.15 surface like `demnerf extract` and caches it there. Throws core::Error (or the library's errors) when a stage fails.
core::TriangleMesh nerfSurface(const NerfSurfaceConfig& config);

}  // namespace demnerf::bench
