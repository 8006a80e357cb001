#include <gtest/gtest.h>

#include <chrono>

#include "nodes/common/rejection_counter.hpp"

// Issue 14: every refusal is counted by cause (the numbers ~status publishes), however many the
// log leaves out.
TEST(RejectionCounter, CountsEveryRefusalByCause) {
  dem_nerf::RejectionCounter counter("test", std::chrono::hours(1));  // logs once per cause here
  for (int i = 0; i < 500; ++i) counter.count("image", "image " + std::to_string(i) + " refused");
  counter.count("particles", "point_step 0");
  EXPECT_EQ(counter.of("image"), 500u);
  EXPECT_EQ(counter.of("particles"), 1u);
  EXPECT_EQ(counter.of("wrench"), 0u);
  EXPECT_EQ(counter.total(), 501u);
  const auto counts = counter.counts();
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0].cause, "image");  // sorted by cause
  EXPECT_EQ(counts[0].count, 500u);
  EXPECT_EQ(counts[0].last_message, "image 499 refused");
  EXPECT_EQ(counts[1].cause, "particles");
}
