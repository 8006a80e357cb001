#include <ATen/Parallel.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>

#include "demnerf/nerf/compositing.hpp"
#include "demnerf/nerf/ray_batch.hpp"
#include "train_worker.hpp"

// One training step in four parts per block of rays: march (rounds of samples), forward (the
// field on each round, activations kept), composite + loss (per ray), backward (per-sample
// gradients, MLP backward, table scatter); then the optimiser and the occupancy schedule.

namespace demnerf::nerf {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

using detail::BlockResult;
using detail::kPriorPoint;
using detail::kTrainBlock;
using detail::Piece;
using detail::Worker;

/// Forward: the field on one round's samples, in pieces that keep their activations.
void forwardRound(const NgpField& field, Worker& st, int total) {
  for (int c = 0; c < total; c += NgpField::kChunk) {
    Piece& pc = st.nextPiece();
    pc.count = std::min(NgpField::kChunk, total - c);
    field.toUnit(st.round.world.data() + 3 * c, pc.count, pc.unit);
    std::copy(st.round.dirs.data() + 3 * c, st.round.dirs.data() + 3 * (c + pc.count), pc.dirs);
    std::copy(st.round.dt.data() + c, st.round.dt.data() + c + pc.count, pc.dt);
    field.forwardChunk(pc.unit, pc.dirs, pc.count, pc.ws, pc.sigma, pc.rgb);
  }
}

/// Composite: adds one round (pieces from first_piece on) to the block's rays, recording per
/// sample what the backward needs (transmittance before it, colour up to it).
void compositeRound(Worker& st, int rays, std::size_t first_piece, float min_t) {
  for (int j = 0; j < rays; ++j) {
    RayAccum& a = st.acc[j];
    for (int s = st.round.first[j]; s < st.round.first[j] + st.round.count[j]; ++s) {
      Piece& pc = *st.pieces[first_piece + s / NgpField::kChunk];
      const int i = s % NgpField::kChunk;
      if (a.transmittance < min_t) {  // opaque earlier in this round: no gradient
        pc.ray[i] = -1;
        continue;
      }
      pc.t_before[i] = a.transmittance;
      const float w = a.add(pc.sigma[i], pc.dt[i], pc.rgb + 3 * i, st.round.t[s]);
      if (st.distortion_grad != 0.0f)
        st.dist[j].add(w, st.round.t[s], pc.dt[i], st.distortion_inv_unit, pc.dist_upto + 4 * i);
      std::copy(a.color, a.color + 3, pc.c_upto + 3 * i);
      pc.ray[i] = j;
      ++st.samples;
    }
    if (a.transmittance < min_t) st.cursors[j].done = true;
  }
}

/// The block's density-prior points (train.density_prior) as one more piece, after its rays'.
void priorPiece(const NerfModel& model, Worker& st, int rays, std::uint64_t seed) {
  const int per_ray = model.config().train.density_prior > 0 ? model.config().train.density_prior_per_ray : 0;
  if (per_ray == 0) return;
  std::mt19937_64 rng(seed);
  float world[3 * NgpField::kChunk];
  Piece& pc = st.nextPiece();
  pc.count = detail::drawPriorPoints(model, st.cursors.data(), st.acc.data(), rays, per_ray,
                                     model.march().min_transmittance, rng, world, pc.dirs);
  if (pc.count == 0) return;
  model.ngp().toUnit(world, pc.count, pc.unit);
  model.ngp().forwardChunk(pc.unit, pc.dirs, pc.count, pc.ws, pc.sigma, pc.rgb);
  std::fill_n(pc.ray, pc.count, kPriorPoint);
}

/// March + forward + composite of one block, round after round, until every ray is done.
void marchBlock(const NerfModel& model, const TrainRays& batch, Worker& st, std::int64_t first, int rays) {
  const float min_t = model.march().min_transmittance;
  for (int j = 0; j < rays; ++j) {
    const std::int64_t r = first + j;
    startRay(model.march(), model.bounds(), batch.origins.data() + 3 * r, batch.directions.data() + 3 * r,
             batch.jitter[r], st.cursors[j]);
    st.acc[j] = RayAccum();
    st.dist[j] = DistortionAccum();
  }
  st.used = 0;
  const int per_round = model.config().march.samples_per_round;
  for (;;) {
    const auto tm = Clock::now();
    const int total = detail::marchRound(model.march(), model.grid(), st.cursors, rays, per_round, st.round);
    st.march_seconds += since(tm);
    if (total == 0) break;
    st.marched += total;
    const std::size_t round_first_piece = st.used;
    forwardRound(model.ngp(), st, total);
    compositeRound(st, rays, round_first_piece, min_t);
  }
}

/// Loss of one block's rays against their targets, and d(loss)/d(ray colour).
void blockLoss(const TrainConfig& train, const TrainRays& batch, Worker& st, std::int64_t first, int rays) {
  const bool huber = train.loss == "huber";
  const float delta = static_cast<float>(train.huber_delta);
  const float grad_scale = 1.0f / (3.0f * static_cast<float>(batch.size()));
  for (int j = 0; j < rays; ++j) {
    const std::int64_t r = first + j;
    const float* target = batch.target.data() + 4 * r;
    st.acc[j].finish(batch.background.data() + 3 * r, st.total_color[j]);
    st.loss += 3.0 * train.distortion * st.dist[j].loss();  // step() divides by 3 x rays
    for (int k = 0; k < 3; ++k) {
      const float bg = batch.background[3 * r + k];
      const float want = target[k] * target[3] + bg * (1.0f - target[3]);
      const float e = st.total_color[j][k] - want;
      st.sq_error += static_cast<double>(e) * e;
      if (huber) {
        const float ae = std::fabs(e);
        st.loss += ae < delta ? 0.5 * e * e / delta : ae - 0.5 * delta;
        st.grad_color[j][k] = (ae < delta ? e / delta : (e > 0 ? 1.0f : -1.0f)) * grad_scale;
      } else {
        st.loss += static_cast<double>(e) * e;
        st.grad_color[j][k] = 2.0f * e * grad_scale;
      }
    }
  }
}

/// The per-sample gradients of one piece from its rays' totals, for the samples that still
/// had min_t of the light (the others' gradients are at most that fraction of their ray's;
/// those behind an opaque point have none), and their activations moved to the first rows so
/// the MLP backward and the table scatter skip the rest.
void selectAndCompact(const NgpField& field, Worker& st, Piece& pc, float min_t, float prior_grad) {
  int kept = 0;
  for (int i = 0; i < pc.count; ++i) {
    const int j = pc.ray[i];
    if (j == kPriorPoint) {  // d(prior)/d(sigma) is the same constant at every point
      std::fill_n(pc.g_rgb + 3 * kept, 3, 0.0f);
      pc.g_sigma[kept] = prior_grad;
      st.keep[kept++] = i;
      continue;
    }
    if (j < 0 || pc.t_before[i] < min_t) continue;
    const float alpha = 1.0f - std::exp(-pc.sigma[i] * pc.dt[i]);
    const float w = pc.t_before[i] * alpha;
    const float t_next = pc.t_before[i] * (1.0f - alpha);
    for (int k = 0; k < 3; ++k) pc.g_rgb[3 * kept + k] = st.grad_color[j][k] * w;
    pc.g_sigma[kept] = colorSigmaGradient(st.grad_color[j], pc.rgb + 3 * i, t_next, st.total_color[j],
                                          pc.c_upto + 3 * i) * pc.dt[i];
    if (st.distortion_grad != 0.0f)
      pc.g_sigma[kept] += st.distortion_grad * pc.dt[i] *
                          distortionSigmaGradient(st.dist[j], pc.dist_upto + 4 * i, w, pc.dt[i], t_next,
                                                  st.distortion_inv_unit);
    st.keep[kept++] = i;
  }
  pc.kept = kept;
  if (kept == pc.count) return;
  // keep[] rises, so moving row keep[r] down to row r never overwrites a row still to move.
  const auto rows = [&](float* a, int width) {
    for (int r = 0; r < kept; ++r)
      if (st.keep[r] != r) std::copy_n(a + static_cast<std::size_t>(st.keep[r]) * width, width, a + r * width);
  };
  const MlpLayout& dl = field.densityLayout();
  const MlpLayout& cl = field.colorLayout();
  rows(pc.ws.encoding.data(), field.hashLayout().outputDims());
  for (int l = 0; l < dl.layers(); ++l) rows(pc.ws.density_act[l].data(), dl.dims[l + 1]);
  rows(pc.ws.color_input.data(), cl.dims[0]);
  for (int l = 0; l < cl.layers(); ++l) rows(pc.ws.color_act[l].data(), cl.dims[l + 1]);
  rows(pc.unit, 3);
}

/// Backward of one block: per-sample gradients from the ray totals, the fused MLP backward,
/// and the samples' encoding gradients queued for the table scatter.
void backwardBlock(const NgpField& field, Worker& st, BlockResult& block, float min_t, float prior_grad) {
  const HashGridLayout& layout = field.hashLayout();
  const int enc_dims = layout.outputDims(), features = layout.features;
  std::int64_t block_samples = 0;
  for (std::size_t p = 0; p < st.used; ++p) {
    selectAndCompact(field, st, *st.pieces[p], min_t, prior_grad);
    block_samples += st.pieces[p]->kept;
  }
  const std::size_t need = static_cast<std::size_t>(st.enc_count + block_samples);
  if (st.enc_pos.size() < 3 * need) st.enc_pos.resize(3 * need * 3 / 2);
  if (st.enc_grad.size() < enc_dims * need) st.enc_grad.resize(enc_dims * need * 3 / 2);
  st.piece_grad.resize(static_cast<std::size_t>(NgpField::kChunk) * enc_dims);
  block.enc_first = st.enc_count;
  block.enc_count = block_samples;
  float* block_grad = st.enc_grad.data() + static_cast<std::size_t>(st.enc_count) * enc_dims;
  std::int64_t done = 0;  // samples of the block already written
  for (std::size_t p = 0; p < st.used; ++p) {
    Piece& pc = *st.pieces[p];
    st.encode_seconds += pc.ws.encode_seconds;
    pc.ws.encode_seconds = 0;
    if (pc.kept == 0) continue;
    field.backwardChunk(pc.kept, pc.ws, pc.g_sigma, pc.g_rgb, block.grads, st.piece_grad.data());
    for (int l = 0; l < layout.levels; ++l) {
      float* dst = block_grad + (l * block_samples + done) * features;
      for (int i = 0; i < pc.kept; ++i)
        for (int f = 0; f < features; ++f) dst[i * features + f] = st.piece_grad[i * enc_dims + l * features + f];
    }
    std::copy(pc.unit, pc.unit + 3 * pc.kept, st.enc_pos.data() + 3 * st.enc_count);
    st.enc_count += pc.kept;
    done += pc.kept;
  }
}

}  // namespace

struct TrainEngine::ThreadState : Worker {};
struct TrainEngine::BlockState : BlockResult {};

TrainEngine::TrainEngine(NerfModel& model) : model_(model) {
  NgpField& f = model.ngp();
  table_moments_.resize(f.table().size());
  density_moments_.resize(f.densityWeights().size());
  color_moments_.resize(f.colorWeights().size());
  table_grad_.assign(f.table().size(), 0.0f);
}

StepResult TrainEngine::step(const TrainRays& batch, float learning_rate) {
  runPasses(batch);
  ++iteration_;
  const TrainConfig& train = model_.config().train;
  AdamHyper h;
  h.learning_rate = learning_rate;
  h.beta1 = static_cast<float>(train.beta1);
  h.beta2 = static_cast<float>(train.beta2);
  h.epsilon = static_cast<float>(train.epsilon);
  h.step = iteration_;
  updateTable(h);
  h.weight_decay = static_cast<float>(train.weight_decay);
  updateMlps(h);
  if ((iteration_ - 1) % model_.config().occupancy.update_interval == 0) {
    const auto t3 = Clock::now();
    model_.grid().update(model_.field(), iteration_ - 1, train.seed);
    times_.occupancy += since(t3);
  }
  StepResult result;
  result.rays = batch.size();
  for (const auto& st : threads_) {
    result.samples += st->samples;
    result.marched += st->marched;
  }
  for (std::int64_t b = 0; b < block_count_; ++b) {
    result.loss += blocks_[b]->loss;
    result.mse += blocks_[b]->sq_error;
  }
  result.loss /= std::max<double>(1.0, 3.0 * batch.size());
  result.mse /= std::max<double>(1.0, 3.0 * batch.size());
  return result;
}

void TrainEngine::runPasses(const TrainRays& batch) {
  const NgpField& field = model_.ngp();
  const std::int64_t n = batch.size();
  const int workers = std::max(1, at::get_num_threads());
  while (static_cast<int>(threads_.size()) < workers) {
    auto state = std::make_shared<ThreadState>();
    const int per_round = model_.config().march.samples_per_round;
    state->round.reserve(kTrainBlock, kTrainBlock * per_round);
    threads_.push_back(state);
  }
  block_count_ = std::max<std::int64_t>(1, (n + kTrainBlock - 1) / kTrainBlock);  // >= 1: updateMlps sums from block 0
  while (static_cast<std::int64_t>(blocks_.size()) < block_count_) {
    auto block = std::make_shared<BlockState>();
    block->grads.density.assign(field.densityWeights().size(), 0.0f);
    block->grads.color.assign(field.colorWeights().size(), 0.0f);
    blocks_.push_back(block);
  }
  const auto t0 = Clock::now();
  double forward_seconds = 0.0, backward_seconds = 0.0, march_share = 0.0, encode_share = 0.0;
  // Blocks go to whichever worker is free (rays differ in samples, so equal slices of rays
  // left one thread waiting for the other).
  std::atomic<std::int64_t> next{0};
  // The density prior, density_prior * sum(sigma * min_step) over its points per ray of the
  // batch; each block draws from a seed of the step and the block (the same on any thread count).
  const TrainConfig& train = model_.config().train;
  // Not during the occupancy grid's warm-up: rays then stop in the initial fog, and the points
  // behind their stops are where the surfaces are still to grow.
  const bool prior_on = train.density_prior > 0 && iteration_ >= model_.config().occupancy.warmup_steps;
  const float prior_grad = static_cast<float>(train.density_prior * model_.march().min_step / std::max<std::int64_t>(1, n));
  at::parallel_for(0, workers, 1, [&](std::int64_t wbegin, std::int64_t wend) {
    for (std::int64_t w = wbegin; w < wend; ++w) {
      Worker& st = *threads_[w];
      st.reset();
      // train.distortion: the mean over the batch's rays of L in units of the box diagonal.
      st.distortion_grad = static_cast<float>(train.distortion / std::max<std::int64_t>(1, n));
      st.distortion_inv_unit = 1.0f / (model_.march().min_step * model_.config().march.steps_per_diagonal);
      double p1 = 0, p2 = 0;
      for (std::int64_t b = next++; b < block_count_; b = next++) {
        BlockResult& block = *blocks_[b];
        block.worker = static_cast<int>(w);
        block.grads.zero();
        const std::int64_t first = b * kTrainBlock;
        const int rays = static_cast<int>(std::min<std::int64_t>(kTrainBlock, n - first));
        const auto tp1 = Clock::now();
        marchBlock(model_, batch, st, first, rays);
        if (prior_on) priorPiece(model_, st, rays, train.seed ^ (0x9e3779b97f4a7c15ull * (iteration_ * 4099 + b + 1)));
        st.loss = st.sq_error = 0;
        blockLoss(train, batch, st, first, rays);
        block.loss = st.loss;
        block.sq_error = st.sq_error;
        const auto tp2 = Clock::now();
        p1 += std::chrono::duration<double>(tp2 - tp1).count();
        backwardBlock(field, st, block, static_cast<float>(train.gradient_min_transmittance), prior_grad);
        p2 += since(tp2);
      }
      if (w == 0) {
        march_share = st.march_seconds / std::max(1e-12, p1);
        encode_share = st.encode_seconds / std::max(1e-12, p1);
        forward_seconds = p1;
        backward_seconds = p2;
      }
    }
  });
  const double parallel_seconds = since(t0);
  // Split the parallel section's wall time between the parts as worker 0 saw it.
  const double p_sum = std::max(1e-12, forward_seconds + backward_seconds);
  const double forward_wall = parallel_seconds * forward_seconds / p_sum;
  times_.march += forward_wall * march_share;
  times_.encode_forward += forward_wall * encode_share;
  times_.march_forward += forward_wall * (1.0 - march_share);
  times_.backward_mlp += parallel_seconds * backward_seconds / p_sum;
}

void TrainEngine::updateTable(const AdamHyper& h) {
  // Levels own disjoint table ranges, so workers take whole levels and update each level's
  // touched entries while they are still in cache. Levels are taken finest first as workers
  // come free: the hashed fine levels cost most, and a fixed split of the level range left
  // one worker with the cheap dense levels.
  NgpField& field = model_.ngp();
  const auto t1 = Clock::now();
  const HashGridLayout& layout = field.hashLayout();
  const int workers = std::max(1, at::get_num_threads());
  const int features = layout.features;
  std::vector<double> table_seconds(layout.levels, 0.0);
  std::atomic<int> next{0};
  at::parallel_for(0, workers, 1, [&](std::int64_t wbegin, std::int64_t wend) {
    for (std::int64_t w = wbegin; w < wend; ++w) {
      for (int k = next++; k < layout.levels; k = next++) {
        const int l = layout.levels - 1 - k;
        const auto ts = Clock::now();
        // Blocks in order: the table gradient is summed in the same order on every run.
        for (std::int64_t b = 0; b < block_count_; ++b) {
          const BlockResult& block = *blocks_[b];
          const Worker& st = *threads_[block.worker];
          const float* grad = st.enc_grad.data() + block.enc_first * layout.outputDims() +
                              static_cast<std::int64_t>(l) * block.enc_count * features;
          hashEncodeBackwardLevel(layout, st.enc_pos.data() + 3 * block.enc_first, block.enc_count, grad, features,
                                  table_grad_.data(), l);
        }
        table_seconds[l] = since(ts);
        // A sequential sweep over the level's gradients streams through memory (visiting a
        // list of touched entries in scatter order would miss the cache on nearly every
        // entry); entries with a zero gradient are skipped, as instant-ngp's optimiser does.
        adamNonzero(h, field.table().data(), table_grad_.data(), table_moments_, layout.offset[l] * features,
                    (layout.offset[l] + layout.entries[l]) * features, field.halfTable());
      }
    }
  });
  const double table_total = since(t1);
  double scatter = 0.0;
  for (double v : table_seconds) scatter += v;
  // Split the section's wall time by the share the scatter took (summed over workers).
  const double share = std::min(1.0, scatter / std::max(1e-12, table_total * std::min(workers, layout.levels)));
  times_.backward_table += table_total * share;
  times_.optimizer += table_total * (1.0 - share);
}

void TrainEngine::updateMlps(const AdamHyper& h) {
  NgpField& field = model_.ngp();
  const auto t2 = Clock::now();
  // Sum the blocks' gradients in block order, then one fused Adam pass.
  MlpGradients& sum = blocks_[0]->grads;
  for (std::int64_t b = 1; b < block_count_; ++b) {
    const MlpGradients& g = blocks_[b]->grads;
    for (std::size_t i = 0; i < sum.density.size(); ++i) sum.density[i] += g.density[i];
    for (std::size_t i = 0; i < sum.color.size(); ++i) sum.color[i] += g.color[i];
  }
  adamDense(h, field.densityWeights().data(), sum.density.data(), density_moments_,
            static_cast<std::int64_t>(field.densityWeights().size()));
  adamDense(h, field.colorWeights().data(), sum.color.data(), color_moments_,
            static_cast<std::int64_t>(field.colorWeights().size()));
  field.refreshMlpCopies();
  times_.optimizer += since(t2);
}

}  // namespace demnerf::nerf
