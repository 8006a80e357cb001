#pragma once
// (private to packages/nerf) One round of marching for a block of rays: every live ray takes
// up to a few samples, stored grouped by ray, front to back. Shared by the renderer and the
// trainer, so both march the same way.

#include <vector>

#include "demnerf/nerf/ray_marcher.hpp"

namespace demnerf::nerf::detail {

/// One round's samples for a block of rays.
struct Round {
  std::vector<float> world, dirs, t, dt, sigma, rgb;
  std::vector<int> first, count;  ///< per block ray
  void reserve(int rays, int samples) {
    world.resize(3 * samples);
    dirs.resize(3 * samples);
    t.resize(samples);
    dt.resize(samples);
    sigma.resize(samples);
    rgb.resize(3 * samples);
    first.resize(rays);
    count.resize(rays);
  }
};

/// Marches every live ray of the block for one round, ray j taking per_ray(j) samples at most;
/// each sample gets its ray's direction. Returns the number of samples.
template <class PerRay>
int marchRoundEach(const MarchParams& params, const OccupancyGrid& grid, std::vector<RayCursor>& cursors, int rays,
                   PerRay per_ray, Round& round) {
  int total = 0;
  for (int j = 0; j < rays; ++j) {
    round.first[j] = total;
    round.count[j] = 0;
    if (cursors[j].done) continue;
    const int got = marchRay(params, grid, cursors[j], per_ray(j), round.world.data() + 3 * total,
                             round.t.data() + total, round.dt.data() + total);
    for (int s = total; s < total + got; ++s)
      for (int a = 0; a < 3; ++a) round.dirs[3 * s + a] = cursors[j].direction[a];
    round.count[j] = got;
    total += got;
  }
  return total;
}

/// The same with per_ray samples for every ray.
inline int marchRound(const MarchParams& params, const OccupancyGrid& grid, std::vector<RayCursor>& cursors,
                      int rays, int per_ray, Round& round) {
  return marchRoundEach(params, grid, cursors, rays, [per_ray](int) { return per_ray; }, round);
}

}  // namespace demnerf::nerf::detail
