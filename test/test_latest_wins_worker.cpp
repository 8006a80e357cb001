#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
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
