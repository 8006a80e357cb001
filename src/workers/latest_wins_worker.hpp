#pragma once
// Runs jobs one at a time on its own thread; a job submitted while another runs replaces any
// job still waiting (latest wins), so a burst of wrench messages costs one solve, not fifty,
// and ROS callbacks never block on the work. An optional least interval between job starts
// keeps a fast stream (a 100 Hz wrench topic with millisecond solves) from taking a whole core
// from other work on the machine (the NeRF training beside it).

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

namespace dem_nerf {

template <typename Job>
class LatestWinsWorker {
 public:
  explicit LatestWinsWorker(std::function<void(const Job&)> work,
                            std::chrono::steady_clock::duration min_interval = std::chrono::steady_clock::duration::zero())
      : work_(std::move(work)), min_interval_(min_interval), thread_([this] { run(); }) {}

  ~LatestWinsWorker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  LatestWinsWorker(const LatestWinsWorker&) = delete;
  LatestWinsWorker& operator=(const LatestWinsWorker&) = delete;

  /// Queues the job; returns true when it replaced one that had not started yet.
  bool submit(Job job) { return exchange(std::move(job)).has_value(); }

  /// Queues the job and hands back the one it replaced (not started yet), so that its owner can
  /// be told (a service caller waiting for it).
  std::optional<Job> exchange(Job job) {
    std::optional<Job> replaced;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      replaced = std::move(waiting_);
      waiting_ = std::move(job);
    }
    wake_.notify_all();
    return replaced;
  }

  /// True while a job runs or waits.
  bool busy() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return running_ || waiting_.has_value();
  }

  /// True while a job waits to start.
  bool busyWithWaiting() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return waiting_.has_value();
  }

  /// Blocks until no job runs or waits (for tests and shutdown).
  void waitIdle() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return !running_ && !waiting_.has_value(); });
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      wake_.wait(lock, [this] { return stopping_ || waiting_.has_value(); });
      if (stopping_) return;
      Job job = std::move(*waiting_);
      waiting_.reset();
      running_ = true;
      const auto started = std::chrono::steady_clock::now();
      lock.unlock();
      work_(job);  // the work reports its own errors; nothing escapes into this thread
      lock.lock();
      running_ = false;
      if (!waiting_) idle_.notify_all();
      // Jobs submitted during this pause coalesce into the one that runs after it.
      if (min_interval_ > std::chrono::steady_clock::duration::zero())
        wake_.wait_until(lock, started + min_interval_, [this] { return stopping_; });
    }
  }

  std::function<void(const Job&)> work_;
  std::chrono::steady_clock::duration min_interval_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<Job> waiting_;
  bool running_ = false;
  bool stopping_ = false;
  std::thread thread_;  // last: starts after every member above exists
};

}  // namespace dem_nerf
