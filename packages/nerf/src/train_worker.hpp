#pragma once
// (private to packages/nerf, train_engine.cpp) What a training step keeps per piece of samples,
// per block of rays and per worker thread between its passes.

#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "demnerf/nerf/compositing.hpp"
#include "demnerf/nerf/distortion.hpp"
#include "demnerf/nerf/model.hpp"
#include "march_round.hpp"

namespace demnerf::nerf::detail {

// Rays per block: its first round still fills two pieces, and a batch of 512 rays makes 8
// blocks, enough for the workers to take them dynamically and finish together.
constexpr int kTrainBlock = 64;
/// Piece::ray of a density-prior point (train.density_prior): no ray, only the prior's gradient.
constexpr int kPriorPoint = -2;
static_assert(4 * kTrainBlock <= NgpField::kChunk, "a block's prior points (<= 4 per ray) fill one piece");

/// Up to kChunk samples of one round, with the activations the backward pass needs, so the
/// backward needs no second forward.
struct Piece {
  FieldWorkspace ws;
  int count = 0;
  float unit[3 * NgpField::kChunk], dirs[3 * NgpField::kChunk];
  float dt[NgpField::kChunk], sigma[NgpField::kChunk], rgb[3 * NgpField::kChunk];
  float t_before[NgpField::kChunk], c_upto[3 * NgpField::kChunk];
  float dist_upto[4 * NgpField::kChunk];  ///< DistortionAccum::add's record (train.distortion > 0 only)
  int ray[NgpField::kChunk];  ///< block ray; -1 when the ray was opaque before this sample; kPriorPoint
  int kept = 0;               ///< samples the backward takes (moved to rows 0..kept)
  float g_sigma[NgpField::kChunk], g_rgb[3 * NgpField::kChunk];  ///< theirs, in that order
};

/// What one block of rays leaves for the reductions after the parallel pass. Workers take
/// blocks in whatever order they come free; the reductions run in block order, so the step's
/// result does not depend on which worker took which block, nor on the thread count.
struct BlockResult {
  int worker = 0;
  std::int64_t enc_first = 0, enc_count = 0;  ///< its samples in the worker's enc buffers
  MlpGradients grads;
  double loss = 0, sq_error = 0;
};

/// Everything one worker thread keeps between the passes and across steps.
struct Worker {
  Round round;
  std::vector<std::unique_ptr<Piece>> pieces;  ///< pool, reused across blocks and steps
  std::size_t used = 0;                        ///< pieces holding this block's samples
  // Inputs of the table backward: positions and d(loss)/d(encoding) of every sample, the
  // gradient level-major within each block (level l of a block of S samples: S x features
  // floats at l * S * features), so each level's scatter streams its inputs.
  std::vector<float> enc_pos, enc_grad, piece_grad;
  std::int64_t enc_count = 0;
  double loss = 0, sq_error = 0;
  double march_seconds = 0, encode_seconds = 0;  // for the time breakdown
  std::int64_t samples = 0, marched = 0;
  std::vector<RayCursor> cursors = std::vector<RayCursor>(kTrainBlock);
  std::vector<RayAccum> acc = std::vector<RayAccum>(kTrainBlock);
  DistortionAccum dist[kTrainBlock];
  // train.distortion: d(loss)/d(a ray's L) (0: off, nothing recorded) and 1 / L's distance unit.
  float distortion_grad = 0.0f, distortion_inv_unit = 0.0f;
  float grad_color[kTrainBlock][3], total_color[kTrainBlock][3];
  int keep[NgpField::kChunk];

  Piece& nextPiece() {
    while (pieces.size() <= used) pieces.push_back(std::make_unique<Piece>());
    return *pieces[used++];
  }
  void reset() {
    loss = sq_error = 0;
    samples = marched = enc_count = 0;
    march_seconds = encode_seconds = 0;
  }
};

/// The density prior's points of one block (train.density_prior): for each ray whose light ran
/// out (transmittance below min_t), up to per_ray points drawn uniformly from 1 to 8 occupancy
/// cells behind where its march stopped, kept where the grid marks the cell occupied (elsewhere
/// the marcher takes no samples). The images say nothing about the density there, so the prior
/// alone decides it. Each point takes its ray's direction (the colour MLP runs on it; its
/// gradient is zero). Writes at most rays * per_ray points; returns how many.
int drawPriorPoints(const NerfModel& model, const RayCursor* cursors, const RayAccum* acc, int rays, int per_ray,
                    float min_t, std::mt19937_64& rng, float* world, float* dirs);

}  // namespace demnerf::nerf::detail
