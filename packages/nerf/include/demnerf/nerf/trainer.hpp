#pragma once
// Trains a NeRF from posed frames: random rays across every frame per batch, Adam with a
// learning-rate schedule, progress reports, frames added and stop requested from other threads.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/nerf/ray_batch.hpp"

namespace demnerf::nerf {

/// What train() reports about once a second (and once at the end).
struct TrainProgress {
  std::int64_t iteration = 0;
  double seconds = 0;           ///< since train() started
  double loss = 0;              ///< smoothed over recent batches
  double psnr = 0;              ///< from the smoothed training MSE
  double rays_per_second = 0;
  double samples_per_second = 0;
  double samples_per_ray = 0;
  double seconds_left = 0;      ///< by the stop criterion (0 when unlimited)
  double occupied_fraction = 0;
  std::size_t frames = 0;
  double learning_rate = 0;
};
using ProgressCallback = std::function<void(const TrainProgress&)>;

/// When train() returns: whichever limit is reached first; 0 means no limit.
struct StopCriteria {
  double seconds = 0;
  std::int64_t iterations = 0;
};

/// Scene box (and aabb_scale) of a dataset as the field wants it.
Box datasetBox(const core::Dataset& dataset);
Box toBox(const Eigen::AlignedBox3d& box);

class Trainer {
 public:
  Trainer(const NerfConfig& config, const Box& bounds, double aabb_scale);
  /// Continues training a saved model (weights and occupancy kept; Adam's moments start fresh).
  explicit Trainer(NerfModel model);
  ~Trainer();

  /// Thread-safe; the frame joins the batches from the next iteration on. The image must be
  /// CV_32FC4 RGBA; throws core::Error naming the frame otherwise.
  void addFrame(const core::Frame& frame);
  void addFrames(const std::vector<core::Frame>& frames);
  std::size_t frameCount() const;
  /// Bounds the frame store (0: unbounded, the default): once addFrame goes past max_frames, the
  /// most redundant frame is evicted, i.e. one of the two whose poses are closest (translation over
  /// the scene box's diagonal plus rotation angle over pi), the older of the two; so a live rig's
  /// store keeps its spread of viewpoints and its memory stays flat. Thread-safe.
  void setMaxFrames(std::size_t max_frames);

  /// Runs `iterations` steps now (no stop criterion: the lr schedule follows setBudget).
  StepResult step(int iterations = 1);
  /// Trains until the criteria are met, requestStop() is called, or forever when both are 0.
  /// Reports progress every `report_seconds` through the callback and, when log is true, on stderr.
  TrainProgress train(const StopCriteria& stop, const ProgressCallback& callback = {}, bool log = true,
                      double report_seconds = 1.0);
  /// Any thread: train() returns after the current iteration.
  void requestStop();
  /// The budget the learning-rate schedule decays over (train() sets it from its criteria).
  void setBudget(const StopCriteria& budget);

  /// A consistent copy of the model, safe to call while another thread trains.
  NerfModel snapshot() const;
  /// The live model; only touch it while no other thread is training.
  NerfModel& model() { return *model_; }
  const StepTimes& times() const { return engine_->times(); }
  std::int64_t iteration() const { return engine_->iteration(); }

 private:
  struct StoredFrame;
  void gatherBatch(std::int64_t rays, TrainRays& batch);
  void evictRedundantFrames();  // with frames_mutex_ held
  /// Keeps the occupancy grid's cells no frame sees empty, when the frame set has changed.
  void refreshVisibility();
  std::uint64_t frames_version_ = 0;       ///< guarded by frames_mutex_; bumped on add and evict
  std::uint64_t visibility_version_ = 0;   ///< frames_version_ the grid's visibility reflects
  std::size_t max_frames_ = 0;  ///< guarded by frames_mutex_
  double learningRate() const;

  NerfConfig config_;
  std::unique_ptr<NerfModel> model_;
  std::unique_ptr<TrainEngine> engine_;
  mutable std::mutex frames_mutex_;
  mutable std::mutex model_mutex_;
  std::vector<std::shared_ptr<StoredFrame>> frames_;
  std::vector<std::int64_t> pixel_offsets_;  ///< cumulative pixel counts for uniform sampling
  std::atomic<bool> stop_requested_{false};
  std::mt19937_64 rng_;
  double samples_per_ray_ = 64.0;  ///< running mean, sizes the next batch
  StopCriteria budget_;
  double elapsed_ = 0.0;           ///< seconds of training so far (for the schedule)
  TrainRays batch_;
};

}  // namespace demnerf::nerf
