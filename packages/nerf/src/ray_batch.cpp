#include "demnerf/nerf/ray_batch.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

namespace demnerf::nerf {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

constexpr int kBlockRays = 64;  // rays marched together; one round is <= 64 * samples_per_round samples

/// One round's samples for a block of rays, grouped by ray (front to back within a ray).
struct Round {
  std::vector<float> world, unit, dirs, t, dt, sigma, rgb;
  std::vector<int> first, count;  ///< per block ray
  void reserve(int samples) {
    world.resize(3 * samples);
    unit.resize(3 * samples);
    dirs.resize(3 * samples);
    t.resize(samples);
    dt.resize(samples);
    sigma.resize(samples);
    rgb.resize(3 * samples);
    first.resize(kBlockRays);
    count.resize(kBlockRays);
  }
};

/// Per-ray compositing state.
struct RayAccum {
  float transmittance = 1.0f, color[3] = {0, 0, 0}, depth = 0.0f;
};

/// Marches the block's live rays for one round and evaluates the field on the samples.
/// Returns the number of samples.
int marchAndEvaluate(const NerfModel& model, std::vector<RayCursor>& cursors, int rays, int per_ray, Round& round,
                     FieldWorkspace& ws, double* march_seconds = nullptr) {
  const auto start = Clock::now();
  const MarchParams& mp = model.renderMarch();
  int total = 0;
  for (int j = 0; j < rays; ++j) {
    round.first[j] = total;
    round.count[j] = 0;
    if (cursors[j].done) continue;
    const int got = marchRay(mp, model.grid(), cursors[j], per_ray, round.world.data() + 3 * total,
                             round.t.data() + total, round.dt.data() + total);
    for (int s = total; s < total + got; ++s)
      for (int a = 0; a < 3; ++a) round.dirs[3 * s + a] = cursors[j].direction[a];
    round.count[j] = got;
    total += got;
  }
  if (march_seconds) *march_seconds += since(start);
  if (total == 0) return 0;
  const NgpField& field = model.field();
  field.toUnit(round.world.data(), total, round.unit.data());
  for (int c = 0; c < total; c += NgpField::kChunk) {
    const int n = std::min(NgpField::kChunk, total - c);
    field.forwardChunk(round.unit.data() + 3 * c, round.dirs.data() + 3 * c, n, ws, round.sigma.data() + c,
                       round.rgb.data() + 3 * c);
  }
  return total;
}

}  // namespace

std::int64_t renderRays(const NerfModel& model, const float* origins, const float* directions, std::int64_t n,
                        const float* background, const RenderOutputs& out) {
  const MarchConfig& mc = model.config().march;
  const float min_t = model.renderMarch().min_transmittance;
  const std::int64_t blocks = (n + kBlockRays - 1) / kBlockRays;
  std::vector<std::int64_t> samples_per_block(blocks, 0);
  at::parallel_for(0, blocks, 1, [&](std::int64_t begin, std::int64_t end) {
    FieldWorkspace ws;
    Round round;
    // Rays get more samples per round as they survive, so long empty-ish rays cost few rounds.
    round.reserve(kBlockRays * std::max(mc.samples_per_round, 32));
    std::vector<RayCursor> cursors(kBlockRays);
    std::vector<RayAccum> acc(kBlockRays);
    for (std::int64_t b = begin; b < end; ++b) {
      const std::int64_t first = b * kBlockRays;
      const int rays = static_cast<int>(std::min<std::int64_t>(kBlockRays, n - first));
      for (int j = 0; j < rays; ++j) {
        startRay(model.renderMarch(), model.bounds(), origins + 3 * (first + j), directions + 3 * (first + j), 0.5f,
                 cursors[j]);
        acc[j] = RayAccum();
      }
      int per_ray = mc.samples_per_round;
      for (;;) {
        const int total = marchAndEvaluate(model, cursors, rays, per_ray, round, ws);
        if (total == 0) break;
        samples_per_block[b] += total;
        for (int j = 0; j < rays; ++j) {
          RayAccum& a = acc[j];
          for (int s = round.first[j]; s < round.first[j] + round.count[j]; ++s) {
            const float alpha = 1.0f - std::exp(-round.sigma[s] * round.dt[s]);
            const float w = a.transmittance * alpha;
            for (int k = 0; k < 3; ++k) a.color[k] += w * round.rgb[3 * s + k];
            a.depth += w * round.t[s];
            a.transmittance *= 1.0f - alpha;
            if (a.transmittance < min_t) {
              cursors[j].done = true;
              break;
            }
          }
        }
        per_ray = std::min(per_ray * 2, std::max(mc.samples_per_round, 32));
      }
      for (int j = 0; j < rays; ++j) {
        const std::int64_t r = first + j;
        for (int k = 0; k < 3; ++k) out.color[3 * r + k] = acc[j].color[k] + acc[j].transmittance * background[k];
        if (out.depth) out.depth[r] = acc[j].depth;
        if (out.opacity) out.opacity[r] = 1.0f - acc[j].transmittance;
      }
    }
  });
  std::int64_t samples = 0;
  for (std::int64_t s : samples_per_block) samples += s;
  return samples;
}

// ---------------------------------------------------------------------------------------

/// Up to kChunk samples of one round, with the activations the backward pass needs, so
/// pass 2 needs no second forward.
struct Piece {
  FieldWorkspace ws;
  int count = 0;
  float unit[3 * NgpField::kChunk], dirs[3 * NgpField::kChunk];
  float dt[NgpField::kChunk], sigma[NgpField::kChunk], rgb[3 * NgpField::kChunk];
  float t_before[NgpField::kChunk], c_upto[3 * NgpField::kChunk];
  int ray[NgpField::kChunk];  ///< block ray; -1 when the ray was opaque before this sample
};

/// Everything one worker thread keeps between the two passes and across steps.
struct TrainEngine::ThreadState {
  Round round;
  MlpGradients grads;
  std::vector<std::unique_ptr<Piece>> pieces;  ///< pool, reused across blocks and steps
  // Inputs of the table backward: positions and d(loss)/d(encoding) of every sample.
  std::vector<float> enc_pos, enc_grad;
  std::int64_t enc_count = 0;
  double loss = 0, sq_error = 0;
  double march_seconds = 0, encode_seconds = 0;  // for the time breakdown
  std::int64_t samples = 0, marched = 0;
  float g_sigma[NgpField::kChunk], g_rgb[3 * NgpField::kChunk];

  Piece& piece(std::size_t i) {
    while (pieces.size() <= i) pieces.push_back(std::make_unique<Piece>());
    return *pieces[i];
  }
};

TrainEngine::TrainEngine(NerfModel& model) : model_(model) {
  NgpField& f = model.field();
  table_moments_.resize(f.table().size());
  density_moments_.resize(f.densityWeights().size());
  color_moments_.resize(f.colorWeights().size());
  table_grad_.assign(f.table().size(), 0.0f);
  touched_.assign(f.hashLayout().total_entries, 0);
}

namespace {

/// Marches every live ray of the block for one round; returns the number of samples.
int marchRound(const NerfModel& model, std::vector<RayCursor>& cursors, int rays, int per_ray, Round& round) {
  int total = 0;
  for (int j = 0; j < rays; ++j) {
    round.first[j] = total;
    round.count[j] = 0;
    if (cursors[j].done) continue;
    const int got = marchRay(model.march(), model.grid(), cursors[j], per_ray, round.world.data() + 3 * total,
                             round.t.data() + total, round.dt.data() + total);
    for (int s = total; s < total + got; ++s)
      for (int a = 0; a < 3; ++a) round.dirs[3 * s + a] = cursors[j].direction[a];
    round.count[j] = got;
    total += got;
  }
  return total;
}

}  // namespace

StepResult TrainEngine::step(const TrainRays& batch, float learning_rate) {
  NgpField& field = model_.field();
  const NerfConfig& config = model_.config();
  const MarchConfig& mc = config.march;
  const float min_t = static_cast<float>(mc.min_transmittance);
  const std::int64_t n = batch.size();
  const int workers = std::max(1, at::get_num_threads());
  while (static_cast<int>(threads_.size()) < workers) {
    auto state = std::make_shared<ThreadState>();
    state->grads.density.assign(field.densityWeights().size(), 0.0f);
    state->grads.color.assign(field.colorWeights().size(), 0.0f);
    threads_.push_back(state);
  }
  const int enc_dims = field.hashLayout().outputDims();
  const bool huber = config.train.loss == "huber";
  const float delta = static_cast<float>(config.train.huber_delta);
  const float grad_scale = 1.0f / (3.0f * static_cast<float>(n));
  constexpr int kTrainBlock = 128;  // rays per block: its first round fills several pieces
  const int per_round = mc.samples_per_round;

  auto t0 = Clock::now();
  double pass1_seconds = 0.0, pass2_seconds = 0.0, march_share = 0.0, encode_share = 0.0;
  // One contiguous slice of rays per worker: the partition, and so the result, depends only
  // on the thread count.
  at::parallel_for(0, workers, 1, [&](std::int64_t wbegin, std::int64_t wend) {
    for (std::int64_t w = wbegin; w < wend; ++w) {
      ThreadState& st = *threads_[w];
      st.loss = st.sq_error = 0;
      st.samples = st.marched = 0;
      st.enc_count = 0;
      st.march_seconds = st.encode_seconds = 0;
      st.grads.zero();
      st.round.reserve(kTrainBlock * per_round);
      st.round.first.resize(kTrainBlock);
      st.round.count.resize(kTrainBlock);
      const std::int64_t rbegin = n * w / workers, rend = n * (w + 1) / workers;
      std::vector<RayCursor> cursors(kTrainBlock);
      std::vector<RayAccum> acc(kTrainBlock);
      float grad_color[kTrainBlock][3];
      float total_color[kTrainBlock][3];
      double p1 = 0, p2 = 0;
      for (std::int64_t first = rbegin; first < rend; first += kTrainBlock) {
        const int rays = static_cast<int>(std::min<std::int64_t>(kTrainBlock, rend - first));
        auto tp1 = Clock::now();
        for (int j = 0; j < rays; ++j) {
          const std::int64_t r = first + j;
          startRay(model_.march(), model_.bounds(), batch.origins.data() + 3 * r, batch.directions.data() + 3 * r,
                   batch.jitter[r], cursors[j]);
          acc[j] = RayAccum();
        }
        // Pass 1: rounds of marching + forward (activations kept per piece) + compositing.
        std::size_t pieces = 0;
        for (;;) {
          auto tm = Clock::now();
          const int total = marchRound(model_, cursors, rays, per_round, st.round);
          st.march_seconds += since(tm);
          if (total == 0) break;
          st.marched += total;
          const std::size_t round_first_piece = pieces;
          field.toUnit(st.round.world.data(), total, st.round.unit.data());
          for (int c = 0; c < total; c += NgpField::kChunk) {
            Piece& pc = st.piece(pieces++);
            pc.count = std::min(NgpField::kChunk, total - c);
            std::copy(st.round.unit.data() + 3 * c, st.round.unit.data() + 3 * (c + pc.count), pc.unit);
            std::copy(st.round.dirs.data() + 3 * c, st.round.dirs.data() + 3 * (c + pc.count), pc.dirs);
            std::copy(st.round.dt.data() + c, st.round.dt.data() + c + pc.count, pc.dt);
            field.forwardChunk(pc.unit, pc.dirs, pc.count, pc.ws, pc.sigma, pc.rgb);
          }
          for (int j = 0; j < rays; ++j) {
            RayAccum& a = acc[j];
            for (int s = st.round.first[j]; s < st.round.first[j] + st.round.count[j]; ++s) {
              Piece& pc = *st.pieces[round_first_piece + s / NgpField::kChunk];
              const int i = s % NgpField::kChunk;
              if (a.transmittance < min_t) {  // opaque earlier in this round: no gradient
                pc.ray[i] = -1;
                continue;
              }
              const float alpha = 1.0f - std::exp(-pc.sigma[i] * pc.dt[i]);
              const float w8 = a.transmittance * alpha;
              pc.t_before[i] = a.transmittance;
              for (int k = 0; k < 3; ++k) {
                a.color[k] += w8 * pc.rgb[3 * i + k];
                pc.c_upto[3 * i + k] = a.color[k];
              }
              pc.ray[i] = j;
              ++st.samples;
              a.transmittance *= 1.0f - alpha;
            }
            if (a.transmittance < min_t) cursors[j].done = true;
          }
        }
        // Loss and its gradient per ray.
        for (int j = 0; j < rays; ++j) {
          const std::int64_t r = first + j;
          const float* target = batch.target.data() + 4 * r;
          const float* bg = batch.background.data() + 3 * r;
          for (int k = 0; k < 3; ++k) {
            const float pred = acc[j].color[k] + acc[j].transmittance * bg[k];
            const float want = target[k] * target[3] + bg[k] * (1.0f - target[3]);
            const float e = pred - want;
            total_color[j][k] = pred;
            st.sq_error += static_cast<double>(e) * e;
            if (huber) {
              const float ae = std::fabs(e);
              st.loss += ae < delta ? 0.5 * e * e / delta : ae - 0.5 * delta;
              grad_color[j][k] = (ae < delta ? e / delta : (e > 0 ? 1.0f : -1.0f)) * grad_scale;
            } else {
              st.loss += static_cast<double>(e) * e;
              grad_color[j][k] = 2.0f * e * grad_scale;
            }
          }
        }
        auto tp2 = Clock::now();
        p1 += std::chrono::duration<double>(tp2 - tp1).count();
        // Pass 2: per-sample gradients from the ray totals, then the fused MLP backward.
        std::int64_t block_samples = 0;
        for (std::size_t p = 0; p < pieces; ++p) block_samples += st.pieces[p]->count;
        const std::size_t need = static_cast<std::size_t>(st.enc_count + block_samples);
        if (st.enc_pos.size() < 3 * need) st.enc_pos.resize(3 * need * 3 / 2);
        if (st.enc_grad.size() < enc_dims * need) st.enc_grad.resize(enc_dims * need * 3 / 2);
        for (std::size_t p = 0; p < pieces; ++p) {
          Piece& pc = *st.pieces[p];
          for (int i = 0; i < pc.count; ++i) {
            const int j = pc.ray[i];
            if (j < 0) {
              st.g_sigma[i] = 0.0f;
              st.g_rgb[3 * i] = st.g_rgb[3 * i + 1] = st.g_rgb[3 * i + 2] = 0.0f;
              continue;
            }
            const float alpha = 1.0f - std::exp(-pc.sigma[i] * pc.dt[i]);
            const float tb = pc.t_before[i];
            const float w8 = tb * alpha;
            const float t_next = tb - w8;
            float g = 0.0f;
            for (int k = 0; k < 3; ++k) {
              const float ck = pc.rgb[3 * i + k];
              // Light from behind this sample: the prediction minus what reached the eye up to it.
              g += grad_color[j][k] * (t_next * ck - (total_color[j][k] - pc.c_upto[3 * i + k]));
              st.g_rgb[3 * i + k] = grad_color[j][k] * w8;
            }
            st.g_sigma[i] = g * pc.dt[i];
          }
          field.backwardChunk(pc.count, pc.ws, st.g_sigma, st.g_rgb, st.grads,
                              st.enc_grad.data() + static_cast<std::size_t>(st.enc_count) * enc_dims);
          std::copy(pc.unit, pc.unit + 3 * pc.count, st.enc_pos.data() + 3 * st.enc_count);
          st.enc_count += pc.count;
          st.encode_seconds += pc.ws.encode_seconds;
          pc.ws.encode_seconds = 0;
        }
        p2 += since(tp2);
      }
      if (w == 0) {
        march_share = st.march_seconds / std::max(1e-12, p1);
        encode_share = st.encode_seconds / std::max(1e-12, p1);
        pass1_seconds = p1;
        pass2_seconds = p2;
      }
    }
  });
  const double parallel_seconds = since(t0);
  // Split the parallel section's wall time between the parts as worker 0 saw it.
  const double p_sum = std::max(1e-12, pass1_seconds + pass2_seconds);
  const double pass1_wall = parallel_seconds * pass1_seconds / p_sum;
  times_.march += pass1_wall * march_share;
  times_.encode_forward += pass1_wall * encode_share;
  times_.march_forward += pass1_wall * (1.0 - march_share);
  times_.backward_mlp += parallel_seconds * pass2_seconds / p_sum;

  // Table gradient and its Adam step: levels own disjoint table ranges, so workers split
  // the levels and update each level's touched entries while they are still in cache.
  auto t1 = Clock::now();
  ++iteration_;
  AdamHyper h;
  h.learning_rate = learning_rate;
  h.beta1 = static_cast<float>(config.train.beta1);
  h.beta2 = static_cast<float>(config.train.beta2);
  h.epsilon = static_cast<float>(config.train.epsilon);
  h.step = iteration_;
  const HashGridLayout& layout = field.hashLayout();
  std::vector<double> table_seconds(layout.levels, 0.0);
  at::parallel_for(0, layout.levels, 1, [&](std::int64_t lbegin, std::int64_t lend) {
    for (std::int64_t l = lbegin; l < lend; ++l) {
      auto ts = Clock::now();
      for (const auto& st : threads_) {
        hashEncodeBackwardTable(layout, st->enc_pos.data(), st->enc_count, st->enc_grad.data(), table_grad_.data(),
                                static_cast<int>(l), static_cast<int>(l + 1), touched_.data());
      }
      table_seconds[l] = since(ts);
      // A sequential sweep over the level's flags streams through memory; visiting a list
      // of touched entries in scatter order would miss the cache on nearly every entry.
      adamTouched(h, field.table().data(), table_grad_.data(), table_moments_, layout.offset[l],
                  layout.offset[l] + layout.entries[l], layout.features, touched_.data());
    }
  });
  const double table_total = since(t1);
  double scatter = 0.0;
  for (double v : table_seconds) scatter += v;
  // Split the section's wall time by the share the scatter took (summed over workers).
  const double share = std::min(1.0, scatter / std::max(1e-12, table_total * std::min(workers, layout.levels)));
  times_.backward_table += table_total * share;
  times_.optimizer += table_total * (1.0 - share);

  auto t2 = Clock::now();
  // MLP gradients: sum the workers' in a fixed order, then one fused Adam pass.
  for (std::size_t w = 1; w < threads_.size(); ++w) {
    for (std::size_t i = 0; i < threads_[0]->grads.density.size(); ++i) threads_[0]->grads.density[i] += threads_[w]->grads.density[i];
    for (std::size_t i = 0; i < threads_[0]->grads.color.size(); ++i) threads_[0]->grads.color[i] += threads_[w]->grads.color[i];
  }
  h.weight_decay = static_cast<float>(config.train.weight_decay);
  adamDense(h, field.densityWeights().data(), threads_[0]->grads.density.data(), density_moments_,
            static_cast<std::int64_t>(field.densityWeights().size()));
  adamDense(h, field.colorWeights().data(), threads_[0]->grads.color.data(), color_moments_,
            static_cast<std::int64_t>(field.colorWeights().size()));
  field.refreshTransposed();
  times_.optimizer += since(t2);

  if ((iteration_ - 1) % config.occupancy.update_interval == 0) {
    auto t3 = Clock::now();
    model_.grid().update(field, iteration_ - 1, config.train.seed);
    times_.occupancy += since(t3);
  }

  StepResult result;
  result.rays = n;
  for (const auto& st : threads_) {
    result.loss += st->loss;
    result.mse += st->sq_error;
    result.samples += st->samples;
    result.marched += st->marched;
  }
  result.loss /= std::max<double>(1.0, 3.0 * n);
  result.mse /= std::max<double>(1.0, 3.0 * n);
  return result;
}

}  // namespace demnerf::nerf
