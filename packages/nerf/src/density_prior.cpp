#include "train_worker.hpp"

namespace demnerf::nerf::detail {

int drawPriorPoints(const NerfModel& model, const RayCursor* cursors, const RayAccum* acc, int rays, int per_ray,
                    float min_t, std::mt19937_64& rng, float* world, float* dirs) {
  const OccupancyGrid& grid = model.grid();
  // From one occupancy cell behind the stop (the surface's own thickness, which the rays that
  // stopped in it did fit) to 8 cells (on the fox 1.5 units: through the head to the wall).
  const float cell = grid.cellSize(0), depth = 7.0f * cell;
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  int drawn = 0;
  for (int j = 0; j < rays; ++j) {
    const RayCursor& c = cursors[j];
    if (acc[j].transmittance >= min_t) continue;  // left the box with light to spare: nothing hidden
    for (int k = 0; k < per_ray; ++k) {
      const float t = c.t + cell + unit(rng) * depth;
      if (t >= c.t_end) continue;
      float* p = world + 3 * drawn;
      for (int a = 0; a < 3; ++a) p[a] = c.origin[a] + t * c.direction[a];
      const std::int64_t index = grid.cellOf(p);
      if (index < 0 || !grid.occupied(index)) continue;
      for (int a = 0; a < 3; ++a) dirs[3 * drawn + a] = c.direction[a];
      ++drawn;
    }
  }
  return drawn;
}

}  // namespace demnerf::nerf::detail
