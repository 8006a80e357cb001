#pragma once
// A fork-join loop over an index range for the solvers' assembly loops (FEM elements, feature-grid
// cells). Private to packages/mechanics/src. Plain std::thread: the chunks are few and long, so a
// pool would save nothing, and the libraries stay free of OpenMP.

#include <algorithm>
#include <thread>
#include <vector>

namespace demnerf::mechanics {

/// The threads an assembly runs on: `requested`, or every core when it is 0.
inline int assemblyThreads(int requested) {
  return requested > 0 ? requested : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

/// Runs fn(chunk, begin, end) over [0, count) split into `threads` contiguous chunks, the first on
/// the calling thread; chunk numbers are 0..threads-1 (per-thread accumulators).
template <typename Fn>
void parallelChunks(long count, int threads, const Fn& fn) {
  if (threads <= 1 || count < 2 * threads) {
    fn(0, 0L, count);
    return;
  }
  std::vector<std::thread> pool;
  const long chunk = (count + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    const long begin = std::min(count, t * chunk), end = std::min(count, (t + 1) * chunk);
    if (begin < end) pool.emplace_back([&fn, t, begin, end] { fn(t, begin, end); });
  }
  fn(0, 0L, std::min(count, chunk));
  for (auto& t : pool) t.join();
}

/// Runs fn(begin, end) over [0, count) split into `threads` contiguous chunks.
template <typename Fn>
void parallelFor(long count, int threads, const Fn& fn) {
  parallelChunks(count, threads, [&fn](int, long begin, long end) { fn(begin, end); });
}

}  // namespace demnerf::mechanics
