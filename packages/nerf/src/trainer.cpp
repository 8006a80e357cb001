#include "demnerf/nerf/trainer.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>

#include "demnerf/core/error.hpp"

namespace demnerf::nerf {

namespace {
using Clock = std::chrono::steady_clock;

bool sameIntrinsics(const core::PinholeCamera& a, const core::PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2;
}
}  // namespace

/// A training image with its camera, stored the way ray generation wants it.
struct Trainer::StoredFrame {
  core::PinholeCamera camera;
  int width = 0, height = 0;
  float rotation[9];  ///< world_from_camera, row-major
  float origin[3];
  std::vector<float> rgba;  ///< height x width x 4
  /// Camera-frame unit directions per pixel, shared between frames with the same lens; only
  /// for distorted cameras, where undistorting per ray would cost more than the lookup.
  std::shared_ptr<const std::vector<float>> directions;
};

Box toBox(const Eigen::AlignedBox3d& aligned) {
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = static_cast<float>(aligned.min()[a]);
    box.max[a] = static_cast<float>(aligned.max()[a]);
  }
  return box;
}

Box datasetBox(const core::Dataset& dataset) { return toBox(dataset.bounds); }

Trainer::Trainer(const NerfConfig& config, const Box& bounds, double aabb_scale)
    : config_(config),
      model_(std::make_unique<NerfModel>(config, bounds, aabb_scale)),
      engine_(std::make_unique<TrainEngine>(*model_)),
      rng_(config.train.seed) {}

Trainer::Trainer(NerfModel model)
    : config_(model.config()),
      model_(std::make_unique<NerfModel>(std::move(model))),
      engine_(std::make_unique<TrainEngine>(*model_)),
      rng_(config_.train.seed) {}

Trainer::~Trainer() = default;

void Trainer::addFrame(const core::Frame& frame) {
  const cv::Mat& image = frame.rgba;
  if (image.empty() || image.type() != CV_32FC4) {
    throw core::Error("frame '" + frame.file_path + "': the trainer needs a loaded CV_32FC4 RGBA image");
  }
  if (image.cols != frame.camera.width || image.rows != frame.camera.height) {
    throw core::Error("frame '" + frame.file_path + "': image is " + std::to_string(image.cols) + "x" +
                      std::to_string(image.rows) + " but its camera says " + std::to_string(frame.camera.width) +
                      "x" + std::to_string(frame.camera.height));
  }
  frame.camera.validate();
  if (!frame.world_from_camera.matrix().allFinite()) {
    throw core::Error("frame '" + frame.file_path + "': pose is not finite");
  }
  auto stored = std::make_shared<StoredFrame>();
  stored->camera = frame.camera;
  stored->width = image.cols;
  stored->height = image.rows;
  const Eigen::Matrix3d r = frame.world_from_camera.linear();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) stored->rotation[3 * i + j] = static_cast<float>(r(i, j));
    stored->origin[i] = static_cast<float>(frame.world_from_camera.translation()[i]);
  }
  stored->rgba.resize(static_cast<std::size_t>(image.rows) * image.cols * 4);
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    std::copy(row, row + 4 * image.cols, stored->rgba.data() + static_cast<std::size_t>(y) * image.cols * 4);
  }
  if (frame.camera.hasDistortion()) {
    std::lock_guard<std::mutex> lock(frames_mutex_);
    for (const auto& other : frames_) {
      if (other->directions && sameIntrinsics(other->camera, frame.camera)) stored->directions = other->directions;
    }
  }
  if (frame.camera.hasDistortion() && !stored->directions) {
    auto table = std::make_shared<std::vector<float>>(static_cast<std::size_t>(image.rows) * image.cols * 3);
    at::parallel_for(0, image.rows, 8, [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t y = begin; y < end; ++y) {
        for (int x = 0; x < image.cols; ++x) {
          const Eigen::Vector3d d = frame.camera.unproject(Eigen::Vector2d(x + 0.5, y + 0.5));
          for (int a = 0; a < 3; ++a) (*table)[(static_cast<std::size_t>(y) * image.cols + x) * 3 + a] = static_cast<float>(d[a]);
        }
      }
    });
    stored->directions = table;
  }
  std::lock_guard<std::mutex> lock(frames_mutex_);
  frames_.push_back(stored);
  const std::int64_t previous = pixel_offsets_.empty() ? 0 : pixel_offsets_.back();
  pixel_offsets_.push_back(previous + static_cast<std::int64_t>(stored->width) * stored->height);
  ++frames_version_;
  evictRedundantFrames();
}

void Trainer::setMaxFrames(std::size_t max_frames) {
  std::lock_guard<std::mutex> lock(frames_mutex_);
  max_frames_ = max_frames;
  evictRedundantFrames();
}

void Trainer::evictRedundantFrames() {
  if (max_frames_ == 0 || frames_.size() <= max_frames_) return;
  const Box box = model_->bounds();
  double diagonal = 0.0;
  for (int a = 0; a < 3; ++a) diagonal += double(box.max[a] - box.min[a]) * double(box.max[a] - box.min[a]);
  diagonal = std::max(std::sqrt(diagonal), 1e-9);
  const auto distance = [diagonal](const StoredFrame& a, const StoredFrame& b) {
    double t = 0.0, trace = 0.0;
    for (int i = 0; i < 3; ++i) t += double(a.origin[i] - b.origin[i]) * double(a.origin[i] - b.origin[i]);
    // trace(Ra^T Rb) = 1 + 2 cos(angle) for the relative rotation.
    for (int k = 0; k < 9; ++k) trace += double(a.rotation[k]) * double(b.rotation[k]);
    const double angle = std::acos(std::clamp((trace - 1.0) / 2.0, -1.0, 1.0));
    return std::sqrt(t) / diagonal + angle / M_PI;
  };
  while (frames_.size() > max_frames_) {
    std::size_t evict = 0;
    double closest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < frames_.size(); ++i)
      for (std::size_t j = i + 1; j < frames_.size(); ++j) {
        const double d = distance(*frames_[i], *frames_[j]);
        if (d < closest) {
          closest = d;
          evict = i;  // the older of the closest pair
        }
      }
    frames_.erase(frames_.begin() + static_cast<std::ptrdiff_t>(evict));
    ++frames_version_;
  }
  pixel_offsets_.clear();
  std::int64_t total = 0;
  for (const auto& frame : frames_) pixel_offsets_.push_back(total += std::int64_t(frame->width) * frame->height);
}

void Trainer::addFrames(const std::vector<core::Frame>& frames) {
  for (const core::Frame& frame : frames) addFrame(frame);
}

std::size_t Trainer::frameCount() const {
  std::lock_guard<std::mutex> lock(frames_mutex_);
  return frames_.size();
}

void Trainer::gatherBatch(std::int64_t rays, TrainRays& batch) {
  std::lock_guard<std::mutex> lock(frames_mutex_);
  if (frames_.empty()) throw core::Error("cannot train: no frames have been added");
  batch.origins.resize(3 * rays);
  batch.directions.resize(3 * rays);
  batch.target.resize(4 * rays);
  batch.background.resize(3 * rays);
  batch.jitter.resize(rays);
  const std::int64_t total = pixel_offsets_.back();
  std::uniform_int_distribution<std::int64_t> pick(0, total - 1);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const bool random_bg = config_.train.random_background;
  for (std::int64_t r = 0; r < rays; ++r) {
    const std::int64_t p = pick(rng_);
    const std::size_t f = static_cast<std::size_t>(
        std::upper_bound(pixel_offsets_.begin(), pixel_offsets_.end(), p) - pixel_offsets_.begin());
    const StoredFrame& frame = *frames_[f];
    const std::int64_t local = p - (f == 0 ? 0 : pixel_offsets_[f - 1]);
    const int x = static_cast<int>(local % frame.width), y = static_cast<int>(local / frame.width);
    float d[3];
    if (frame.directions) {
      for (int a = 0; a < 3; ++a) d[a] = (*frame.directions)[3 * local + a];
    } else {
      d[0] = static_cast<float>((x + 0.5 - frame.camera.cx) / frame.camera.fx);
      d[1] = static_cast<float>((y + 0.5 - frame.camera.cy) / frame.camera.fy);
      d[2] = 1.0f;
    }
    float world[3], norm = 0.0f;
    for (int i = 0; i < 3; ++i) {
      world[i] = frame.rotation[3 * i] * d[0] + frame.rotation[3 * i + 1] * d[1] + frame.rotation[3 * i + 2] * d[2];
      norm += world[i] * world[i];
    }
    norm = 1.0f / std::sqrt(norm);
    for (int i = 0; i < 3; ++i) {
      batch.origins[3 * r + i] = frame.origin[i];
      batch.directions[3 * r + i] = world[i] * norm;
    }
    std::copy(frame.rgba.data() + 4 * local, frame.rgba.data() + 4 * local + 4, batch.target.data() + 4 * r);
    for (int k = 0; k < 3; ++k) {
      batch.background[3 * r + k] = random_bg ? unit(rng_) : static_cast<float>(config_.background[k]);
    }
    batch.jitter[r] = unit(rng_);
  }
}

void Trainer::setBudget(const StopCriteria& budget) { budget_ = budget; }

double Trainer::learningRate() const {
  // Constant, then exponential decay to final ratio over the last part of the budget.
  double progress = 0.0;
  if (budget_.seconds > 0) progress = std::max(progress, elapsed_ / budget_.seconds);
  if (budget_.iterations > 0) progress = std::max(progress, static_cast<double>(engine_->iteration()) / budget_.iterations);
  const TrainConfig& t = config_.train;
  if (progress <= t.decay_start || t.decay_start >= 1.0) return t.learning_rate;
  const double x = std::min(1.0, (progress - t.decay_start) / (1.0 - t.decay_start));
  return t.learning_rate * std::pow(t.final_learning_rate_ratio, x);
}

void Trainer::refreshVisibility() {
  std::vector<GridCamera> cameras;
  {
    std::lock_guard<std::mutex> lock(frames_mutex_);
    if (frames_version_ == visibility_version_) return;
    visibility_version_ = frames_version_;
    for (const auto& frame : frames_) {
      GridCamera camera;
      std::copy(frame->rotation, frame->rotation + 9, camera.rotation);
      std::copy(frame->origin, frame->origin + 3, camera.origin);
      camera.fx = static_cast<float>(frame->camera.fx);
      camera.fy = static_cast<float>(frame->camera.fy);
      camera.cx = static_cast<float>(frame->camera.cx);
      camera.cy = static_cast<float>(frame->camera.cy);
      camera.width = frame->width;
      camera.height = frame->height;
      cameras.push_back(camera);
    }
  }
  std::lock_guard<std::mutex> lock(model_mutex_);
  model_->grid().setVisibility(cameras);
}

StepResult Trainer::step(int iterations) {
  StepResult last;
  for (int i = 0; i < iterations; ++i) {
    // The cells the cameras see change with the frame set; checked on the occupancy schedule.
    if (engine_->iteration() % config_.occupancy.update_interval == 0) refreshVisibility();
    const TrainConfig& t = config_.train;
    const std::int64_t rays = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(t.target_samples / std::max(1.0, samples_per_ray_)), t.min_rays, t.max_rays);
    auto start = Clock::now();
    gatherBatch(rays, batch_);
    {
      std::lock_guard<std::mutex> lock(model_mutex_);
      last = engine_->step(batch_, static_cast<float>(learningRate()));
    }
    elapsed_ += std::chrono::duration<double>(Clock::now() - start).count();
    const double per_ray = static_cast<double>(last.marched) / std::max<std::int64_t>(1, last.rays);
    samples_per_ray_ = 0.8 * samples_per_ray_ + 0.2 * std::max(1.0, per_ray);
  }
  return last;
}

void Trainer::requestStop() { stop_requested_ = true; }

NerfModel Trainer::snapshot() const {
  std::lock_guard<std::mutex> lock(model_mutex_);
  return *model_;
}

TrainProgress Trainer::train(const StopCriteria& stop, const ProgressCallback& callback, bool log,
                             double report_seconds) {
  stop_requested_ = false;
  setBudget(stop);
  elapsed_ = 0.0;
  const auto start = Clock::now();
  auto last_report = start;
  const std::int64_t first_iteration = engine_->iteration();
  TrainProgress progress;
  double loss_avg = -1, mse_avg = -1;
  std::int64_t rays_window = 0, samples_window = 0, marched_window = 0;
  auto report = [&](bool final_report) {
    const double now = std::chrono::duration<double>(Clock::now() - start).count();
    const double window = std::max(1e-9, std::chrono::duration<double>(Clock::now() - last_report).count());
    progress.iteration = engine_->iteration();
    progress.seconds = now;
    progress.loss = loss_avg;
    progress.psnr = mse_avg > 0 ? -10.0 * std::log10(mse_avg) : 0.0;
    if (rays_window > 0 || !final_report) {
      progress.rays_per_second = rays_window / window;
      progress.samples_per_second = samples_window / window;
      progress.samples_per_ray = rays_window ? static_cast<double>(marched_window) / rays_window : 0.0;
    }
    double left = 0.0;
    if (stop.seconds > 0) left = std::max(0.0, stop.seconds - now);
    if (stop.iterations > 0) {
      const double per_it = now / std::max<std::int64_t>(1, progress.iteration - first_iteration);
      const double by_it = per_it * std::max<std::int64_t>(0, first_iteration + stop.iterations - progress.iteration);
      left = stop.seconds > 0 ? std::min(left, by_it) : by_it;
    }
    progress.seconds_left = left;
    progress.occupied_fraction = model_->grid().occupiedFraction();
    progress.frames = frameCount();
    progress.learning_rate = learningRate();
    if (log) {
      std::fprintf(stderr,
                   "nerf: it %lld  loss %.5f  psnr %.2f dB  %.0f rays/s  %.0f samples/s  %.1f samples/ray  "
                   "occupied %.1f%%  %.0f s left\n",
                   static_cast<long long>(progress.iteration), progress.loss, progress.psnr, progress.rays_per_second,
                   progress.samples_per_second, progress.samples_per_ray, 100.0 * progress.occupied_fraction,
                   progress.seconds_left);
    }
    if (callback) callback(progress);
    rays_window = samples_window = marched_window = 0;
    last_report = Clock::now();
  };
  for (;;) {
    if (stop_requested_) break;
    if (stop.iterations > 0 && engine_->iteration() - first_iteration >= stop.iterations) break;
    const double now = std::chrono::duration<double>(Clock::now() - start).count();
    if (stop.seconds > 0 && now >= stop.seconds) break;
    if (frameCount() == 0) {
      // A node may start training before its first keyframe arrives.
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    const StepResult r = step(1);
    loss_avg = loss_avg < 0 ? r.loss : 0.9 * loss_avg + 0.1 * r.loss;
    mse_avg = mse_avg < 0 ? r.mse : 0.9 * mse_avg + 0.1 * r.mse;
    rays_window += r.rays;
    samples_window += r.samples;
    marched_window += r.marched;
    if (std::chrono::duration<double>(Clock::now() - last_report).count() >= report_seconds) report(false);
  }
  report(true);
  return progress;
}

}  // namespace demnerf::nerf
