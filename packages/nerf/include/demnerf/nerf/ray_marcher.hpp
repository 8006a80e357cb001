#pragma once
// Ray marching through the scene box: steps that grow with distance (cone tracing), cells the
// occupancy grid marks empty are skipped whole, and the caller stops a ray once it is opaque.

#include <cstdint>

#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/occupancy_grid.hpp"

namespace demnerf::nerf {

/// Step sizes in metres, derived from the config and the box.
struct MarchParams {
  float min_step = 0, max_step = 0, cone_angle = 0, near = 0;
  float max_step_cells = 1;  ///< the largest step in a cascade, in that cascade's cells
  float min_transmittance = 0;  ///< rays stop once less light than this gets through
  int max_samples = 0;
  static MarchParams make(const MarchConfig& config, const Box& bounds, double aabb_scale, int grid_resolution);
  /// The coarser marching of renders (render_cone_angle, render_min_transmittance).
  static MarchParams makeRender(const MarchConfig& config, const Box& bounds, double aabb_scale, int grid_resolution);
};

/// Where one ray is in its march.
struct RayCursor {
  float origin[3], direction[3];
  float t = 0, t_end = 0;
  int taken = 0;      ///< samples produced so far
  bool done = false;  ///< left the box or hit max_samples (the caller also sets it when opaque)
};

/// Sets up a cursor at the box entry (not before `near`), shifted by jitter * first step
/// (jitter in [0, 1) decorrelates training samples). done when the ray misses the box.
void startRay(const MarchParams& params, const Box& bounds, const float* origin, const float* direction,
              float jitter, RayCursor& cursor);

/// Appends up to `count` samples (midpoints, 3 floats each; t and dt) in occupied cells.
int marchRay(const MarchParams& params, const OccupancyGrid& grid, RayCursor& cursor, int count, float* positions,
             float* t, float* dt);

}  // namespace demnerf::nerf
