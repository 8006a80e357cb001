// The hash encoding's half-precision forward against the float forward it replaces.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "demnerf/nerf/hash_encoding.hpp"

namespace demnerf::nerf {
namespace {

// Dense and hashed levels, and a point count that is not a multiple of the 16-point gathers so
// the scalar tail runs too.
TEST(HashEncoding, HalfTableForwardMatchesFloatWithinRounding) {
  if (!halfTableSupported()) GTEST_SKIP() << "this build has no half-precision forward";
  HashGridConfig config;
  config.levels = 6;
  config.log2_table_size = 10;
  config.base_resolution = 4;
  config.finest_resolution = 200;
  const HashGridLayout layout = HashGridLayout::make(config);
  ASSERT_TRUE(layout.dense.front());
  ASSERT_FALSE(layout.dense.back());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> value(-2.0f, 2.0f), unit(0.0f, 1.0f);
  std::vector<float> table(layout.parameterCount());
  for (float& v : table) v = value(rng);
  std::vector<std::uint16_t> half(table.size());
  toHalf(table.data(), 0, static_cast<std::int64_t>(table.size()), half.data());
  const int n = 300;
  std::vector<float> points(3 * n), exact(n * layout.outputDims()), rounded(n * layout.outputDims());
  for (float& p : points) p = unit(rng);
  hashEncodeForward(layout, table.data(), points.data(), n, exact.data());
  hashEncodeForwardHalf(layout, half.data(), points.data(), n, rounded.data());
  double largest = 0.0;
  for (std::size_t i = 0; i < exact.size(); ++i) largest = std::max(largest, double(std::fabs(exact[i] - rounded[i])));
  // A half keeps 11 significant bits: entries up to 2 round by at most 2^-10, and the
  // trilinear weights sum to one.
  EXPECT_LT(largest, 1.0 / 1024.0);
  EXPECT_GT(largest, 0.0);  // it is the rounded copy that was read
}

TEST(HashEncoding, HalfTableNeedsTwoFeatures) {
  if (!halfTableSupported()) GTEST_SKIP() << "this build has no half-precision forward";
  HashGridConfig config;
  config.features_per_level = 4;
  const HashGridLayout layout = HashGridLayout::make(config);
  std::vector<std::uint16_t> half(layout.parameterCount());
  float point[3] = {0.5f, 0.5f, 0.5f};
  std::vector<float> out(layout.outputDims());
  EXPECT_ANY_THROW(hashEncodeForwardHalf(layout, half.data(), point, 1, out.data()));
}

}  // namespace
}  // namespace demnerf::nerf
