#pragma once
// Batched rendering and training of rays: marching in rounds of a few samples per ray, the
// field evaluated on each round's samples, compositing that stops opaque rays early.

#include <cstdint>
#include <vector>

#include "demnerf/nerf/adam.hpp"
#include "demnerf/nerf/model.hpp"

namespace demnerf::nerf {

struct RenderOutputs {
  float* color;    ///< [n x 3]
  float* depth;    ///< [n] expected distance along the ray (m), or null
  float* opacity;  ///< [n], or null
};

/// Where rays march: step sizes, the occupancy grid that skips empty space, the box.
struct MarchScene {
  const MarchParams& params;
  const OccupancyGrid& grid;
  Box bounds;
  int samples_per_round;  ///< first round's samples per ray; later rounds double up to 32
};

/// The one marching + compositing path of every renderer: renders n rays (origins, unit
/// directions: n x 3) through any field over `background` (3 floats). Threaded over blocks of
/// rays; the field is queried once per round with all the block's samples. Returns the number
/// of field samples evaluated.
std::int64_t renderRays(const Field& field, const MarchScene& scene, const float* origins, const float* directions,
                        std::int64_t n, const float* background, const RenderOutputs& out);

/// renderRays through the model's field with its render marching.
std::int64_t renderRays(const NerfModel& model, const float* origins, const float* directions, std::int64_t n,
                        const float* background, const RenderOutputs& out);

/// One training batch: rays with their target colour (RGBA) and background.
struct TrainRays {
  std::vector<float> origins, directions;  ///< n x 3
  std::vector<float> target;               ///< n x 4 (RGBA; alpha 1 for opaque data)
  std::vector<float> background;           ///< n x 3
  std::vector<float> jitter;               ///< n, in [0, 1)
  std::int64_t size() const { return static_cast<std::int64_t>(jitter.size()); }
};

struct StepResult {
  double loss = 0;        ///< the configured loss
  double mse = 0;         ///< mean squared colour error (for PSNR)
  std::int64_t rays = 0;
  std::int64_t samples = 0;  ///< samples that took part in compositing (forward + backward)
  std::int64_t marched = 0;  ///< samples evaluated in the forward rounds
};

/// Wall seconds spent per component, summed over steps.
struct StepTimes {
  double march = 0;           ///< ray marching (occupancy lookups, stepping)
  double march_forward = 0;   ///< forward rounds (field) + compositing + loss
  double backward_mlp = 0;    ///< per-sample gradients + MLP backward
  double encode_forward = 0;  ///< part of march_forward: the hash encoding
  double backward_table = 0;  ///< hash table gradient scatter
  double optimizer = 0;
  double occupancy = 0;
  double total() const { return march + march_forward + backward_mlp + backward_table + optimizer + occupancy; }
};

/// Owns the optimizer state of one model and runs training steps on it.
class TrainEngine {
 public:
  explicit TrainEngine(NerfModel& model);
  /// Forward, backward and Adam on one batch; updates the occupancy grid on its schedule.
  StepResult step(const TrainRays& rays, float learning_rate);
  std::int64_t iteration() const { return iteration_; }
  const StepTimes& times() const { return times_; }

 private:
  struct ThreadState;
  struct BlockState;
  /// March, forward, composite + loss and backward of every ray, split over the workers.
  void runPasses(const TrainRays& rays);
  /// Hash table gradient scatter and its Adam step.
  void updateTable(const AdamHyper& hyper);
  /// Sum of the workers' MLP gradients and their Adam step.
  void updateMlps(const AdamHyper& hyper);
  NerfModel& model_;
  std::int64_t iteration_ = 0;
  AdamMoments table_moments_, density_moments_, color_moments_;
  std::vector<float> table_grad_;
  std::vector<std::shared_ptr<ThreadState>> threads_;
  std::vector<std::shared_ptr<BlockState>> blocks_;  ///< per block of rays, reused across steps
  std::int64_t block_count_ = 0;                      ///< blocks of the latest batch
  StepTimes times_;
};

}  // namespace demnerf::nerf
