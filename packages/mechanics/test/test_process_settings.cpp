// parkBlasThreads ends OpenBLAS's workers only where the process allowed it and while no other
// thread marks BLAS calls in flight (BlasCallsInFlight): OpenBLAS's shutdown does not wait for a
// call on another thread, and dem_node's render worker makes such calls beside its solves.
#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "demnerf/mechanics/process_settings.hpp"

namespace dm = demnerf::mechanics;

TEST(BlasThreadParking, SkipsWhileAnotherThreadHasBlasCallsInFlightAndWhenNotAllowed) {
  dm::allowBlasThreadParking(true);
  const bool has_openblas = dm::parkBlasThreads();  // false only in a build against another BLAS
  std::promise<void> marked, done;
  std::thread renderer([&] {
    const dm::BlasCallsInFlight calls;
    marked.set_value();
    done.get_future().wait();
  });
  marked.get_future().wait();
  EXPECT_FALSE(dm::parkBlasThreads()) << "ended OpenBLAS's workers while another thread had BLAS calls in flight";
  done.set_value();
  renderer.join();
  EXPECT_EQ(dm::parkBlasThreads(), has_openblas) << "no longer ends them once the other thread's calls are done";
  dm::allowBlasThreadParking(false);
  EXPECT_FALSE(dm::parkBlasThreads()) << "ended them without the process allowing it";
}
