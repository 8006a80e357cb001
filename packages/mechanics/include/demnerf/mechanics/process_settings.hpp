#pragma once
// Process-wide settings the DEM and the PINN run faster with. The library applies none of them
// behind its caller's back: entry points do (dem_nerf::configureRuntime in the nodes and the CLI,
// the benchmarks' mains), except the solvers' own thread count for the length of a solve.

namespace demnerf::mechanics {

/// Every Adam step allocates and frees the same few-MB tensors; glibc serves blocks above its
/// mmap threshold with fresh zeroed pages each time (page faults were ~15 % of a step). Raising
/// the mmap and trim thresholds keeps them in the heap, which halves the step time at T-bar sizes.
void keepLargeAllocationsInHeap();

/// Torch's CPU matmuls go to the system BLAS (OpenBLAS on Debian), whose own thread pool ignores
/// at::set_num_threads; its spinning workers made a T-bar step 1.8x slower on a loaded 2-core
/// machine. Found through dlsym so a build against another BLAS still links (then a no-op).
void setBlasThreads(int threads);

/// Ends OpenBLAS's worker threads now; its next threaded call starts them again (~0.1 ms). Idle,
/// they spin on sched_yield for ~0.1 s (its THREAD_TIMEOUT, read only at load) before they sleep,
/// and took a core from the Gauss-Newton steps' own threads after every factor (docs/
/// dem_feature_grid.md, "A faster Gauss-Newton step"). A no-op without OpenBLAS, unless the
/// process allowed it (allowBlasThreadParking), and while another thread holds a
/// BlasCallsInFlight. Returns whether the workers were ended.
bool parkBlasThreads();

/// Lets parkBlasThreads end OpenBLAS's workers; off by default. OpenBLAS's shutdown does not wait
/// for a call in flight on another thread, whose workers can then miss the exit and leave the
/// shutdown joining them forever. So a process allows it only where every other thread that calls
/// BLAS while a solve runs holds a BlasCallsInFlight around those calls: `demnerf` and the
/// solver matrix bench (one thread), dem_node (its render worker around each render).
void allowBlasThreadParking(bool allowed);

/// Marks BLAS calls in flight on this thread for its lifetime: parkBlasThreads, on the solving
/// thread, skips the shutdown meanwhile. Any number of threads may hold one at once.
class BlasCallsInFlight {
 public:
  BlasCallsInFlight();
  ~BlasCallsInFlight();
  BlasCallsInFlight(const BlasCallsInFlight&) = delete;
  BlasCallsInFlight& operator=(const BlasCallsInFlight&) = delete;
};

}  // namespace demnerf::mechanics
