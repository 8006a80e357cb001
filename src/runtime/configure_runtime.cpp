#include "runtime/configure_runtime.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <thread>

#include "demnerf/mechanics/process_settings.hpp"

namespace dem_nerf {

void configureRuntime(const RuntimeOptions& options) {
  const int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  at::set_num_threads(threads);
  demnerf::mechanics::setBlasThreads(threads);  // OpenBLAS's pool ignores torch's count
  if (options.keep_large_allocations) demnerf::mechanics::keepLargeAllocationsInHeap();
  demnerf::mechanics::allowBlasThreadParking(options.park_blas_threads);
}

}  // namespace dem_nerf
