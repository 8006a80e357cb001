#pragma once
// The process-wide settings each entry point (a node's main, a `demnerf` command) makes once,
// before any work, so that no library constructor changes the process behind its caller's back.

namespace dem_nerf {

struct RuntimeOptions {
  /// Torch's intra-op threads and OpenBLAS's threads (0: every core). Torch keeps the count in a
  /// global that each thread picks up at its first parallel operation, so setting it here reaches
  /// the nodes' worker and training threads too. The DEM and the PINN still choose their own count
  /// for the length of a solve, on the solving thread (one below 50k particles; see
  /// docs/ARCHITECTURE.md, "Threads").
  int threads = 0;
  /// Raise glibc's mmap and trim thresholds: per-step tensors of a few MB are then reused from the
  /// heap instead of fresh zeroed pages (page faults were ~15 % of a DEM Adam step; this halves
  /// the step at T-bar sizes). DemConfig::tune_allocator. Off for nerf_node, whose memory is
  /// better returned to the system between its phases.
  bool keep_large_allocations = false;
  /// The Gauss-Newton DEM may end OpenBLAS's spinning workers after each factor
  /// (demnerf::mechanics::allowBlasThreadParking). Only for a process whose other threads hold a
  /// BlasCallsInFlight around their BLAS calls: `demnerf` (one thread), dem_node (its renders).
  bool park_blas_threads = false;
};

void configureRuntime(const RuntimeOptions& options);

}  // namespace dem_nerf
