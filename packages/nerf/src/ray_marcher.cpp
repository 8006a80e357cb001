#include "demnerf/nerf/ray_marcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace demnerf::nerf {

MarchParams MarchParams::make(const MarchConfig& config, const Box& bounds, double aabb_scale, int grid_resolution) {
  MarchParams p;
  double diagonal = 0.0, smallest_cell = std::numeric_limits<double>::max();
  for (int a = 0; a < 3; ++a) {
    diagonal += static_cast<double>(bounds.size(a)) * bounds.size(a);
    smallest_cell = std::min(smallest_cell, static_cast<double>(bounds.size(a)) / grid_resolution);
  }
  diagonal = std::sqrt(diagonal);
  p.min_step = static_cast<float>(diagonal / config.steps_per_diagonal);
  p.max_step = static_cast<float>(std::max<double>(p.min_step, config.max_step_cells * smallest_cell));
  p.max_step_cells = static_cast<float>(config.max_step_cells);
  p.cone_angle = static_cast<float>(config.cone_angle >= 0 ? config.cone_angle : (aabb_scale > 1.0 ? 1.0 / 256 : 0.0));
  p.near = static_cast<float>(config.near);
  p.min_transmittance = static_cast<float>(config.min_transmittance);
  p.max_samples = config.max_samples;
  return p;
}

MarchParams MarchParams::makeRender(const MarchConfig& config, const Box& bounds, double aabb_scale,
                                    int grid_resolution) {
  MarchParams p = make(config, bounds, aabb_scale, grid_resolution);
  const bool unbounded = aabb_scale > 1.0;
  if (config.render_cone_angle >= 0) p.cone_angle = static_cast<float>(config.render_cone_angle);
  else if (unbounded) p.cone_angle = std::max(p.cone_angle, 1.0f / 128);
  if (config.render_min_transmittance >= 0) p.min_transmittance = static_cast<float>(config.render_min_transmittance);
  else if (unbounded) p.min_transmittance = std::max(p.min_transmittance, 0.01f);
  return p;
}

void startRay(const MarchParams& params, const Box& bounds, const float* origin, const float* direction,
              float jitter, RayCursor& c) {
  float t0 = params.near, t1 = std::numeric_limits<float>::max();
  for (int a = 0; a < 3; ++a) {
    c.origin[a] = origin[a];
    c.direction[a] = direction[a];
    const float inv = 1.0f / direction[a];  // +-inf for axis-parallel rays is handled by min/max
    float ta = (bounds.min[a] - origin[a]) * inv, tb = (bounds.max[a] - origin[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (std::isnan(ta) || std::isnan(tb)) continue;  // origin on the slab boundary, parallel ray
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  c.taken = 0;
  c.t_end = t1;
  c.done = !(t0 < t1);
  const float step = std::min(std::max(t0 * params.cone_angle, params.min_step), params.max_step);
  c.t = t0 + jitter * step;
}

int marchRay(const MarchParams& params, const OccupancyGrid& grid, RayCursor& c, int count, float* positions,
             float* t_out, float* dt_out) {
  float inv_dir[3];
  for (int a = 0; a < 3; ++a) inv_dir[a] = 1.0f / c.direction[a];
  // Largest step per cascade: cells double in size outwards, and so may the steps.
  float max_step[8];
  for (int k = 0; k < grid.cascades() && k < 8; ++k) {
    max_step[k] = std::max(params.min_step, params.max_step_cells * grid.cellSize(k));
  }
  int produced = 0;
  float t = c.t;
  while (produced < count && !c.done) {
    if (t >= c.t_end || c.taken >= params.max_samples) {
      c.done = true;
      break;
    }
    // The cascade where the step starts sets its largest size.
    float p[3];
    for (int a = 0; a < 3; ++a) p[a] = c.origin[a] + t * c.direction[a];
    const int k = grid.cascadeOf(p);
    const float dt = std::min(std::max(t * params.cone_angle, params.min_step), max_step[k < 0 ? 0 : k]);
    const float mid = t + 0.5f * dt;
    for (int a = 0; a < 3; ++a) p[a] = c.origin[a] + mid * c.direction[a];
    const std::int64_t cell = grid.cellOf(p);
    if (cell < 0) {
      t += dt;
      continue;
    }
    if (grid.occupied(cell)) {
      for (int a = 0; a < 3; ++a) positions[3 * produced + a] = p[a];
      t_out[produced] = mid;
      dt_out[produced] = dt;
      ++produced;
      ++c.taken;
      t += dt;
      continue;
    }
    // Empty cell: jump to where the ray leaves it, then keep stepping on the step grid.
    const int cascade = static_cast<int>(cell / grid.cellsPerCascade());
    const float next = std::max(grid.cellExit(cascade, p, c.origin, inv_dir), mid);
    t += std::ceil((next - t) / dt) * dt;  // whole steps keep samples aligned with the jitter
  }
  c.t = t;
  return produced;
}

}  // namespace demnerf::nerf
