#include "runtime/configure_runtime.hpp"

#include <ATen/Parallel.h>
#include <dlfcn.h>
#include <malloc.h>

#include <algorithm>
#include <thread>

namespace dem_nerf {
namespace {

/// Torch's CPU matmuls go to the system BLAS (OpenBLAS on Debian), whose own thread pool ignores
/// at::set_num_threads. Found through dlsym so a build against another BLAS still links.
void setBlasThreads(int threads) {
  using SetThreads = void (*)(int);
  if (auto f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(threads);
}

}  // namespace

void configureRuntime(const RuntimeOptions& options) {
  const int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  at::set_num_threads(threads);
  setBlasThreads(threads);
  if (options.keep_large_allocations) {
    mallopt(M_MMAP_THRESHOLD, 512 * 1024 * 1024);
    mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
  }
}

}  // namespace dem_nerf
