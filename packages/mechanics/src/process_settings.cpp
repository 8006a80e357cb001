#include "demnerf/mechanics/process_settings.hpp"

#include <dlfcn.h>
#include <malloc.h>

#include <atomic>

namespace demnerf::mechanics {
namespace {
std::atomic<bool> blas_parking_allowed{false};
}  // namespace

void keepLargeAllocationsInHeap() {
  mallopt(M_MMAP_THRESHOLD, 512 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
}

void setBlasThreads(int threads) {
  using SetThreads = void (*)(int);
  if (auto f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(threads);
}

void parkBlasThreads() {
  using Shutdown = int (*)();
  static const auto shutdown = reinterpret_cast<Shutdown>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"));
  if (shutdown && blas_parking_allowed.load()) shutdown();
}

void allowBlasThreadParking(bool allowed) { blas_parking_allowed.store(allowed); }

}  // namespace demnerf::mechanics
