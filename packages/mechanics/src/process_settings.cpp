#include "demnerf/mechanics/process_settings.hpp"

#include <dlfcn.h>
#include <malloc.h>

#include <atomic>
#include <mutex>
#include <shared_mutex>

namespace demnerf::mechanics {
namespace {
std::atomic<bool> blas_parking_allowed{false};
std::shared_mutex blas_calls_in_flight;  // shared by BlasCallsInFlight, tried exclusively by parkBlasThreads
}  // namespace

void keepLargeAllocationsInHeap() {
  mallopt(M_MMAP_THRESHOLD, 512 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
}

void setBlasThreads(int threads) {
  using SetThreads = void (*)(int);
  if (auto f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(threads);
}

bool parkBlasThreads() {
  using Shutdown = int (*)();
  static const auto shutdown = reinterpret_cast<Shutdown>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"));
  if (!shutdown || !blas_parking_allowed.load()) return false;
  // Skipped, not waited for: the workers then spin a while, which costs less than stalling a step.
  const std::unique_lock<std::shared_mutex> no_calls_elsewhere(blas_calls_in_flight, std::try_to_lock);
  if (!no_calls_elsewhere.owns_lock()) return false;
  shutdown();
  return true;
}

void allowBlasThreadParking(bool allowed) { blas_parking_allowed.store(allowed); }

BlasCallsInFlight::BlasCallsInFlight() { blas_calls_in_flight.lock_shared(); }

BlasCallsInFlight::~BlasCallsInFlight() { blas_calls_in_flight.unlock_shared(); }

}  // namespace demnerf::mechanics
