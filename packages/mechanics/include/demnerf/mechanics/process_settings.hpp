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
/// dem_feature_grid.md, "A faster Gauss-Newton step"). A no-op without OpenBLAS, and unless the
/// process allowed it (allowBlasThreadParking).
void parkBlasThreads();

/// Lets parkBlasThreads end OpenBLAS's workers; off by default. Only a process that calls BLAS
/// from one thread at a time may allow it: OpenBLAS's shutdown does not wait for a call in flight
/// on another thread, whose workers can then miss the exit and leave the shutdown joining them
/// forever. `demnerf` and the benchmarks allow it; dem_node does not (its render worker runs the
/// NeRF's matmuls beside a solve).
void allowBlasThreadParking(bool allowed);

}  // namespace demnerf::mechanics
