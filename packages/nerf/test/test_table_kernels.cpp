// The hash table's training kernels (the level scatter the training step runs, without touched
// flags, and the table Adam over non-zero gradients) against plain implementations written
// here from their definitions.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/adam.hpp"
#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/hash_encoding.hpp"

namespace demnerf::nerf {
namespace {

HashGridLayout testLayout() {
  HashGridConfig c;
  c.levels = 5;
  c.features_per_level = 2;
  c.log2_table_size = 10;  // 3 dense levels, 2 hashed
  c.base_resolution = 4;
  c.finest_resolution = 96;
  return HashGridLayout::make(c);
}

// instant-ngp's encoding, written out: corner (x, y, z) of the point's cell, its trilinear
// weight, and its entry (row-major on a dense level, the xor of primes on a hashed one).
void referenceScatter(const HashGridLayout& layout, int level, const std::vector<float>& pos, const float* grad,
                      std::vector<double>& table_grad) {
  const int res = layout.resolution[level];
  const std::int64_t n = static_cast<std::int64_t>(pos.size() / 3);
  for (std::int64_t i = 0; i < n; ++i) {
    int cell[3];
    double frac[3];
    for (int a = 0; a < 3; ++a) {
      const float x = std::clamp(pos[3 * i + a], 0.0f, 1.0f) * static_cast<float>(res);
      cell[a] = std::min(static_cast<int>(x), res - 1);
      frac[a] = x - static_cast<float>(cell[a]);
    }
    for (int corner = 0; corner < 8; ++corner) {
      std::uint32_t c[3];
      double w = 1.0;
      for (int a = 0; a < 3; ++a) {
        const int d = (corner >> a) & 1;
        c[a] = static_cast<std::uint32_t>(cell[a] + d);
        w *= d ? frac[a] : 1.0 - frac[a];
      }
      std::uint32_t e;
      if (layout.dense[level]) {
        const std::uint32_t s = static_cast<std::uint32_t>(res) + 1;
        e = (c[2] * s + c[1]) * s + c[0];
      } else {
        e = (c[0] ^ (c[1] * 2654435761u) ^ (c[2] * 805459861u)) & layout.hash_mask;
      }
      for (int f = 0; f < 2; ++f) table_grad[(layout.offset[level] + e) * 2 + f] += w * grad[2 * i + f];
    }
  }
}

// Runs of samples along rays (consecutive points a small step apart share cells on the coarse
// levels, so entries sum many samples) mixed with scattered points and clamped ones, and a
// count that is not a multiple of the kernel's 256-point runs.
std::vector<float> rayLikePoints(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-0.05f, 1.05f), step(-0.004f, 0.004f);
  std::vector<float> pos(3 * n);
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) pos[3 * i + a] = (i % 16 == 0 || i == 0) ? u(rng) : pos[3 * (i - 1) + a] + step(rng);
  return pos;
}

TEST(TableKernels, LevelScatterEqualsPlainReference) {
  const HashGridLayout layout = testLayout();
  const int n = 8 * 75 + 5;
  std::mt19937 rng(3);
  const std::vector<float> pos = rayLikePoints(n, rng);
  std::uniform_real_distribution<float> g(-1.0f, 1.0f);
  std::vector<float> grad(static_cast<std::size_t>(layout.levels) * n * 2);  // level-major
  for (float& v : grad) v = g(rng);
  std::vector<float> got(layout.parameterCount(), 0.0f);
  std::vector<double> want(got.size(), 0.0);
  std::vector<std::uint8_t> touched(layout.total_entries, 0);
  for (int l = 0; l < layout.levels; ++l) {
    const float* level_grad = grad.data() + static_cast<std::size_t>(l) * n * 2;
    hashEncodeBackwardLevel(layout, pos.data(), n, level_grad, 2, got.data(), l, touched.data());
    referenceScatter(layout, l, pos, level_grad, want);
  }
  double largest = 0.0;
  for (double v : want) largest = std::max(largest, std::fabs(v));
  ASSERT_GT(largest, 1.0);  // entries summed from many samples: rounding order shows
  int written = 0;
  for (std::size_t k = 0; k < got.size(); ++k) {
    ASSERT_NEAR(got[k], want[k], 1e-5 * largest) << "parameter " << k;
    written += want[k] != 0.0;
  }
  EXPECT_GT(written, 1000);
  // Every entry a sample reached is flagged, and no other (weights may vanish, so compare
  // with the reference's corner set rather than its sums).
  std::vector<std::uint8_t> reached(layout.total_entries, 0);
  for (int l = 0; l < layout.levels; ++l) {
    std::vector<float> ones(static_cast<std::size_t>(n) * 2, 1.0f);
    std::vector<double> hits(got.size(), 0.0);
    referenceScatter(layout, l, pos, ones.data(), hits);
    for (std::int64_t e = layout.offset[l]; e < layout.offset[l] + layout.entries[l]; ++e) reached[e] = hits[2 * e] != 0.0;
  }
  for (std::int64_t e = 0; e < layout.total_entries; ++e)
    if (reached[e]) ASSERT_EQ(touched[e], 1) << "entry " << e;
}

TEST(TableKernels, ScatterIsRepeatable) {
  // The training step's result must not depend on anything but its inputs (one and two
  // threads train to the same bits): the same scatter twice gives the same bits.
  const HashGridLayout layout = testLayout();
  const int n = 1000;
  std::mt19937 rng(9);
  const std::vector<float> pos = rayLikePoints(n, rng);
  std::vector<float> grad(static_cast<std::size_t>(n) * 2);
  std::uniform_real_distribution<float> g(-1.0f, 1.0f);
  for (float& v : grad) v = g(rng);
  std::vector<float> a(layout.parameterCount(), 0.0f), b(a);
  for (int l = 0; l < layout.levels; ++l) {
    hashEncodeBackwardLevel(layout, pos.data(), n, grad.data(), 2, a.data(), l);
    hashEncodeBackwardLevel(layout, pos.data(), n, grad.data(), 2, b.data(), l);
  }
  EXPECT_EQ(a, b);
}

TEST(TableKernels, AdamNonzeroEqualsPlainAdamOnTouchedParameters) {
  const std::int64_t size = 16 * 40 + 11, begin = 5, end = size - 3;  // unaligned ends: scalar head and tail
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> params(size), grads(size);
  AdamMoments moments;
  moments.resize(size);
  for (std::int64_t i = 0; i < size; ++i) {
    params[i] = u(rng);
    grads[i] = (i % 3 == 0 || ((i - begin) / 16) % 5 == 2) ? 0.0f : 1e-2f * u(rng);  // whole vectors untouched too
    moments.m[i] = 1e-3f * u(rng);
    moments.v[i] = 1e-5f * std::fabs(u(rng));
  }
  std::vector<std::uint16_t> half(size, 0x7c00);  // +inf: must stay where nothing changed
  AdamHyper h;
  h.learning_rate = 1e-2f;
  h.weight_decay = 1e-3f;
  h.step = 7;
  const std::vector<float> p0 = params, g0 = grads, m0 = moments.m, v0 = moments.v;
  adamNonzero(h, params.data(), grads.data(), moments, begin, end, halfTableSupported() ? half.data() : nullptr);
  const double bias = std::sqrt(1.0 - std::pow(0.99, 7.0)) / (1.0 - std::pow(0.9, 7.0));
  for (std::int64_t i = 0; i < size; ++i) {
    const bool updated = i >= begin && i < end && g0[i] != 0.0f;
    if (!updated) {
      EXPECT_EQ(params[i], p0[i]) << i;
      EXPECT_EQ(moments.m[i], m0[i]) << i;
      EXPECT_EQ(moments.v[i], v0[i]) << i;
      EXPECT_EQ(half[i], 0x7c00) << i;
      continue;
    }
    const double grad = double(g0[i]) + 1e-3 * p0[i];
    const double m = 0.9 * m0[i] + 0.1 * grad, v = 0.99 * v0[i] + 0.01 * grad * grad;
    const double p = p0[i] - 1e-2 * bias * m / (std::sqrt(v) + 1e-15);
    // Float rounding of the terms (which may cancel), not of their sum.
    EXPECT_NEAR(moments.m[i], m, 1e-6 * (0.9 * std::fabs(m0[i]) + 0.1 * std::fabs(grad)) + 1e-12) << i;
    EXPECT_NEAR(moments.v[i], v, 1e-5 * v + 1e-15) << i;
    EXPECT_NEAR(params[i], p, 1e-6) << i;
    EXPECT_EQ(grads[i], 0.0f) << i;
    if (halfTableSupported()) {
      std::vector<std::uint16_t> one(1);
      toHalf(&params[i], 0, 1, one.data());
      EXPECT_EQ(half[i], one[0]) << i;
    }
  }
}

TEST(TableKernels, GradientTransmittanceCutIsAFraction) {
  EXPECT_DOUBLE_EQ(parseNerfConfig("train: {gradient_min_transmittance: 0.01}").train.gradient_min_transmittance, 0.01);
  EXPECT_DOUBLE_EQ(NerfConfig{}.train.gradient_min_transmittance, 0.0);  // every sample, as before
  EXPECT_THROW(parseNerfConfig("train: {gradient_min_transmittance: 1.0}"), core::Error);
  EXPECT_THROW(parseNerfConfig("train: {gradient_min_transmittance: -0.1}"), core::Error);
}

}  // namespace
}  // namespace demnerf::nerf
