#include "demnerf/nerf/ray_batch.hpp"

#include <ATen/Parallel.h>

#include <algorithm>

#include "demnerf/nerf/compositing.hpp"
#include "march_round.hpp"

namespace demnerf::nerf {
namespace {

constexpr int kBlockRays = 64;  // rays marched together; one round is <= 64 * 32 samples

/// Samples ray j takes in the next round. A round's samples past the point where its ray turns
/// opaque are computed for nothing, so a ray that has already lost much of its light (it is
/// inside a surface) takes few; a clear ray takes `clear`, which grows round by round so that long
/// rays through thin fog cost few rounds.
int roundBudget(const RayAccum& acc, int clear) {
  if (acc.transmittance > 0.5f) return clear;
  return acc.transmittance > 0.1f ? std::min(clear, 4) : 2;
}

/// Composites one round's samples onto the block's rays; a ray that turns opaque is done.
void compositeRound(const detail::Round& round, int rays, float min_transmittance, std::vector<RayAccum>& acc,
                    std::vector<RayCursor>& cursors) {
  for (int j = 0; j < rays; ++j) {
    RayAccum& a = acc[j];
    for (int s = round.first[j]; s < round.first[j] + round.count[j]; ++s) {
      a.add(round.sigma[s], round.dt[s], round.rgb.data() + 3 * s, round.t[s]);
      if (a.transmittance < min_transmittance) {
        cursors[j].done = true;
        break;
      }
    }
  }
}

}  // namespace

std::int64_t renderRays(const Field& field, const MarchScene& scene, const float* origins, const float* directions,
                        std::int64_t n, const float* background, const RenderOutputs& out) {
  const std::int64_t blocks = (n + kBlockRays - 1) / kBlockRays;
  const int max_per_round = std::max(scene.samples_per_round, 32);
  std::vector<std::int64_t> samples_per_block(blocks, 0);
  at::parallel_for(0, blocks, 1, [&](std::int64_t begin, std::int64_t end) {
    detail::Round round;
    round.reserve(kBlockRays, kBlockRays * max_per_round);
    std::vector<RayCursor> cursors(kBlockRays);
    std::vector<RayAccum> acc(kBlockRays);
    for (std::int64_t b = begin; b < end; ++b) {
      const std::int64_t first = b * kBlockRays;
      const int rays = static_cast<int>(std::min<std::int64_t>(kBlockRays, n - first));
      for (int j = 0; j < rays; ++j) {
        startRay(scene.params, scene.bounds, origins + 3 * (first + j), directions + 3 * (first + j), 0.5f,
                 cursors[j]);
        acc[j] = RayAccum();
      }
      // Rays get more samples per round as they survive, so long empty-ish rays cost few rounds.
      for (int per_ray = scene.samples_per_round;; per_ray = std::min(per_ray * 2, max_per_round)) {
        const int total = detail::marchRoundEach(
            scene.params, scene.grid, cursors, rays, [&](int j) { return roundBudget(acc[j], per_ray); }, round);
        if (total == 0) break;
        samples_per_block[b] += total;
        // Inside this parallel region the field's own parallel_for runs inline on this thread.
        field.query(round.world.data(), round.dirs.data(), total, round.sigma.data(), round.rgb.data());
        compositeRound(round, rays, scene.params.min_transmittance, acc, cursors);
      }
      for (int j = 0; j < rays; ++j) {
        const std::int64_t r = first + j;
        acc[j].finish(background, out.color + 3 * r);
        if (out.depth) out.depth[r] = acc[j].depth;
        if (out.opacity) out.opacity[r] = 1.0f - acc[j].transmittance;
      }
    }
  });
  std::int64_t samples = 0;
  for (std::int64_t s : samples_per_block) samples += s;
  return samples;
}

std::int64_t renderRays(const NerfModel& model, const float* origins, const float* directions, std::int64_t n,
                        const float* background, const RenderOutputs& out) {
  const MarchScene scene{model.renderMarch(), model.grid(), model.bounds(), model.config().march.samples_per_round};
  return renderRays(model.field(), scene, origins, directions, n, background, out);
}

}  // namespace demnerf::nerf
