#pragma once
// A process-wide allocator setting the DEM and the PINN run faster with. The library never
// applies it by itself: entry points do, once (dem_nerf::configureRuntime in the nodes and the
// CLI, from DemConfig::tune_allocator; the benchmarks' mains).

namespace demnerf::mechanics {

/// Every Adam step allocates and frees the same few-MB tensors; glibc serves blocks above its
/// mmap threshold with fresh zeroed pages each time (page faults were ~15 % of a step). Raising
/// the mmap and trim thresholds keeps them in the heap, which halves the step time at T-bar sizes.
void keepLargeAllocationsInHeap();

}  // namespace demnerf::mechanics
