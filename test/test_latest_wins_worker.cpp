#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <vector>

#include "workers/latest_wins_worker.hpp"

TEST(LatestWinsWorker, ABurstCoalescesToTheNewestJob) {
  std::mutex mutex;
  std::vector<int> done;
  std::atomic<bool> started{false}, release{false};
  dem_nerf::LatestWinsWorker<int> worker([&](const int& job) {
    started = true;
    while (job == 0 && !release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::lock_guard<std::mutex> lock(mutex);
    done.push_back(job);
  });
  worker.submit(0);  // occupies the worker until released
  while (!started) std::this_thread::yield();
  EXPECT_FALSE(worker.submit(1));
  EXPECT_TRUE(worker.submit(2));
  EXPECT_TRUE(worker.submit(3));
  release = true;
  worker.waitIdle();
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(done, (std::vector<int>{0, 3}));
}

TEST(LatestWinsWorker, DestroysCleanlyWithWorkPending) {
  std::atomic<int> runs{0};
  {
    dem_nerf::LatestWinsWorker<int> worker([&](const int&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
      ++runs;
    });
    worker.submit(1);
    worker.submit(2);
  }
  EXPECT_LE(runs.load(), 2);
}

TEST(LatestWinsWorker, AStreamFasterThanTheLeastIntervalIsThinnedToIt) {
  using Clock = std::chrono::steady_clock;
  std::mutex mutex;
  std::vector<std::pair<int, Clock::time_point>> starts;
  dem_nerf::LatestWinsWorker<int> worker(
      [&](const int& job) {
        std::lock_guard<std::mutex> lock(mutex);
        starts.emplace_back(job, Clock::now());
      },
      std::chrono::milliseconds(100));
  // 50 jobs at ~500 Hz: instant work, so without the interval every one would run.
  const Clock::time_point first = Clock::now();
  for (int i = 0; i < 50; ++i) {
    worker.submit(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto stream = Clock::now() - first;  // ~0.1 s, longer on a loaded machine
  worker.waitIdle();
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // a job may still follow the pause
  worker.waitIdle();
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_GE(starts.size(), 2u);
  const auto allowed = static_cast<std::size_t>(stream / std::chrono::milliseconds(100)) + 2;
  EXPECT_LE(starts.size(), allowed) << "a 100 ms interval allows one start per 100 ms of the stream, plus the last";
  EXPECT_EQ(starts.back().first, 49) << "the newest job is the one that runs last";
  for (std::size_t i = 1; i < starts.size(); ++i)
    EXPECT_GE(starts[i].second - starts[i - 1].second, std::chrono::milliseconds(99));
}

// dem_node answers a ~solve caller whose waiting job was replaced: exchange hands the job back.
TEST(LatestWinsWorker, ExchangeHandsBackTheReplacedJob) {
  std::atomic<bool> started{false}, release{false};
  dem_nerf::LatestWinsWorker<int> worker([&](const int& job) {
    started = true;
    while (job == 0 && !release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  worker.submit(0);
  while (!started) std::this_thread::yield();
  EXPECT_FALSE(worker.exchange(1).has_value());
  EXPECT_TRUE(worker.busyWithWaiting());
  const std::optional<int> replaced = worker.exchange(2);
  ASSERT_TRUE(replaced.has_value());
  EXPECT_EQ(*replaced, 1);
  release = true;
  worker.waitIdle();
  EXPECT_FALSE(worker.busyWithWaiting());
}
