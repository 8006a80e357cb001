#include "demnerf/nerf/hash_encoding.hpp"

#include <algorithm>
#include <cmath>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "demnerf/core/error.hpp"
#include "hash_level_run.hpp"

namespace demnerf::nerf {
namespace {

using detail::kPrime1;
using detail::kPrime2;
using detail::kRun;
using detail::LevelRun;
using detail::levelRun;

/// The 8 corner entries (relative to the level's offset) and trilinear weights of one point.
struct Corners {
  std::uint32_t index[8];
  float weight[8];
  float frac[3];
};

inline void corners(const HashGridLayout& layout, int level, const float* p, Corners& c) {
  const int res = layout.resolution[level];
  int cell[3];
  for (int a = 0; a < 3; ++a) {
    const float x = std::min(std::max(p[a], 0.0f), 1.0f) * static_cast<float>(res);
    const int i = std::min(static_cast<int>(x), res - 1);
    cell[a] = i;
    c.frac[a] = x - static_cast<float>(i);
  }
  const float wx[2] = {1.0f - c.frac[0], c.frac[0]};
  const float wy[2] = {1.0f - c.frac[1], c.frac[1]};
  const float wz[2] = {1.0f - c.frac[2], c.frac[2]};
  if (layout.dense[level]) {
    const std::uint32_t stride = static_cast<std::uint32_t>(res) + 1;
    const std::uint32_t base = (static_cast<std::uint32_t>(cell[2]) * stride + cell[1]) * stride + cell[0];
    for (int k = 0; k < 8; ++k) {
      const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
      c.index[k] = base + dx + dy * stride + dz * stride * stride;
      c.weight[k] = wx[dx] * wy[dy] * wz[dz];
    }
  } else {
    const std::uint32_t hx[2] = {static_cast<std::uint32_t>(cell[0]), static_cast<std::uint32_t>(cell[0]) + 1};
    const std::uint32_t hy[2] = {static_cast<std::uint32_t>(cell[1]) * kPrime1,
                                 (static_cast<std::uint32_t>(cell[1]) + 1) * kPrime1};
    const std::uint32_t hz[2] = {static_cast<std::uint32_t>(cell[2]) * kPrime2,
                                 (static_cast<std::uint32_t>(cell[2]) + 1) * kPrime2};
    for (int k = 0; k < 8; ++k) {
      const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
      c.index[k] = (hx[dx] ^ hy[dy] ^ hz[dz]) & layout.hash_mask;
      c.weight[k] = wx[dx] * wy[dy] * wz[dz];
    }
  }
}

// Two features per entry (the default): an entry is 8 bytes, so one 64-bit gather fetches
// a corner's features for 8 points and one FMA weighs all 16 floats. Returns the points done
// (a multiple of 8); the caller's scalar loop takes the rest, and all of them without AVX-512.
inline int gatherPairs(const float* level_table, const LevelRun& run, int m, float* out, int dims) {
  int i = 0;
#if defined(__AVX512F__)
  // Lane 2p and 2p+1 take point p's weight.
  const __m512i dup = _mm512_set_epi32(7, 7, 6, 6, 5, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0);
  for (; i + 8 <= m; i += 8) {
    __m512 acc = _mm512_setzero_ps();
    for (int k = 0; k < 8; ++k) {
      const __m256i idx = _mm256_load_si256(reinterpret_cast<const __m256i*>(&run.index[k][i]));
      const __m512d pairs = _mm512_i32gather_pd(idx, level_table, 8);
      const __m512 w = _mm512_permutexvar_ps(dup, _mm512_castps256_ps512(_mm256_load_ps(&run.weight[k][i])));
      acc = _mm512_fmadd_ps(w, _mm512_castpd_ps(pairs), acc);
    }
    alignas(64) float lanes[16];
    _mm512_store_ps(lanes, acc);
    for (int p = 0; p < 8; ++p) {
      out[(i + p) * dims] = lanes[2 * p];
      out[(i + p) * dims + 1] = lanes[2 * p + 1];
    }
  }
#else
  (void)level_table, (void)run, (void)m, (void)out, (void)dims;
#endif
  return i;
}

// Levels form the outer loop so one level's table slice stays in cache across the points;
// all corner addresses of a run are known (and prefetched) before the first gather, so the
// cache misses overlap instead of queueing one after another.
template <int F>
void forwardImpl(const HashGridLayout& layout, const float* table, const float* positions, std::int64_t n,
                 float* out) {
  const int dims = layout.levels * F;
  thread_local LevelRun run;
  for (std::int64_t first = 0; first < n; first += kRun) {
    const int m = static_cast<int>(std::min<std::int64_t>(kRun, n - first));
    const float* p = positions + 3 * first;
    float* o = out + first * dims;
    for (int level = 0; level < layout.levels; ++level) {
      const float* level_table = table + layout.offset[level] * F;
      levelRun(layout, level, p, m, run);
      if (!layout.dense[level]) {
        for (int k = 0; k < 8; k += 2)  // x-neighbours (k, k+1) usually share a cache line
          for (int i = 0; i < m; ++i) __builtin_prefetch(level_table + static_cast<std::size_t>(run.index[k][i]) * F);
      }
      int i = 0;
      if constexpr (F == 2) i = gatherPairs(level_table, run, m, o + level * F, dims);
      for (; i < m; ++i) {
        float acc[F] = {};
        for (int k = 0; k < 8; ++k) {
          const float* entry = level_table + static_cast<std::size_t>(run.index[k][i]) * F;
          const float w = run.weight[k][i];
          for (int f = 0; f < F; ++f) acc[f] += w * entry[f];
        }
        for (int f = 0; f < F; ++f) o[i * dims + level * F + f] = acc[f];
      }
    }
  }
}

// One level's scatter; sample i's F gradient floats sit at grad + i * stride, so the same
// kernel reads the row-major encoding gradient (stride levels * F) or a level-major copy
// (stride F: a contiguous stream that leaves L2 to the level's table gradient).
template <int F>
void backwardLevelImpl(const HashGridLayout& layout, const float* positions, std::int64_t n, const float* grad,
                       std::int64_t stride, float* grad_table, int level, std::uint8_t* touched) {
  thread_local LevelRun run;
  const std::int64_t offset = layout.offset[level];
  float* level_grad = grad_table + offset * F;
  std::uint8_t* level_touched = touched ? touched + offset : nullptr;
  for (std::int64_t first = 0; first < n; first += kRun) {
    const int m = static_cast<int>(std::min<std::int64_t>(kRun, n - first));
    levelRun(layout, level, positions + 3 * first, m, run);
    if (!layout.dense[level]) {
      for (int k = 0; k < 8; k += 2)
        for (int i = 0; i < m; ++i) __builtin_prefetch(level_grad + static_cast<std::size_t>(run.index[k][i]) * F, 1);
    }
    const float* g_first = grad + first * stride;
    for (int i = 0; i < m; ++i) {
      const float* g = g_first + i * stride;
      for (int k = 0; k < 8; ++k) {
        const std::uint32_t e = run.index[k][i];
        float* entry = level_grad + static_cast<std::size_t>(e) * F;
        const float w = run.weight[k][i];
        for (int f = 0; f < F; ++f) entry[f] += w * g[f];
        if (level_touched) level_touched[e] = 1;
      }
    }
  }
}

template <int F>
void backwardPositionsImpl(const HashGridLayout& layout, const float* table, const float* positions,
                           std::int64_t n, const float* grad_out, float* grad_positions) {
  const int dims = layout.levels * F;
  Corners c;
  for (std::int64_t i = 0; i < n; ++i) {
    const float* p = positions + 3 * i;
    float gp[3] = {0, 0, 0};
    for (int level = 0; level < layout.levels; ++level) {
      corners(layout, level, p, c);
      const float* level_table = table + layout.offset[level] * F;
      const float* g = grad_out + i * dims + level * F;
      const float res = static_cast<float>(layout.resolution[level]);
      const float w[3][2] = {{1 - c.frac[0], c.frac[0]}, {1 - c.frac[1], c.frac[1]}, {1 - c.frac[2], c.frac[2]}};
      for (int k = 0; k < 8; ++k) {
        const int d[3] = {k & 1, (k >> 1) & 1, (k >> 2) & 1};
        const float* entry = level_table + static_cast<std::int64_t>(c.index[k]) * F;
        float dot = 0;
        for (int f = 0; f < F; ++f) dot += g[f] * entry[f];
        // d(weight)/d(x_a): the factor along a is +1 or -1 (times res), the others unchanged.
        for (int a = 0; a < 3; ++a) {
          float dw = (d[a] ? 1.0f : -1.0f) * res;
          for (int b = 0; b < 3; ++b) if (b != a) dw *= w[b][d[b]];
          gp[a] += dot * dw;
        }
      }
    }
    for (int a = 0; a < 3; ++a) {
      // Clamped coordinates do not move the encoding.
      grad_positions[3 * i + a] = (p[a] < 0.0f || p[a] > 1.0f) ? 0.0f : gp[a];
    }
  }
}

template <template <int> class K, typename... Args>
void dispatch(int features, Args&&... args) {
  switch (features) {
    case 1: return K<1>::run(args...);
    case 2: return K<2>::run(args...);
    case 4: return K<4>::run(args...);
    case 8: return K<8>::run(args...);
    default:
      throw core::Error("hash encoding: features_per_level must be 1, 2, 4 or 8, got " + std::to_string(features));
  }
}
template <int F> struct Fwd { template <typename... A> static void run(A&&... a) { forwardImpl<F>(a...); } };
template <int F> struct BwdL { template <typename... A> static void run(A&&... a) { backwardLevelImpl<F>(a...); } };
template <int F> struct BwdP { template <typename... A> static void run(A&&... a) { backwardPositionsImpl<F>(a...); } };

}  // namespace

HashGridLayout HashGridLayout::make(const HashGridConfig& config, double aabb_scale) {
  if (config.features_per_level != 1 && config.features_per_level != 2 && config.features_per_level != 4 &&
      config.features_per_level != 8) {
    throw core::Error("hash.features_per_level must be 1, 2, 4 or 8, got " + std::to_string(config.features_per_level));
  }
  HashGridLayout layout;
  layout.levels = config.levels;
  layout.features = config.features_per_level;
  const std::int64_t table = std::int64_t{1} << config.log2_table_size;
  layout.hash_mask = static_cast<std::uint32_t>(table - 1);
  const double finest = config.finest_resolution > 0 ? config.finest_resolution : 512.0 * std::max(1.0, aabb_scale);
  const double base = config.base_resolution;
  const double growth = config.levels > 1 ? std::exp((std::log(finest) - std::log(base)) / (config.levels - 1)) : 1.0;
  std::int64_t offset = 0;
  for (int l = 0; l < config.levels; ++l) {
    const int res = static_cast<int>(std::floor(base * std::pow(growth, l) + 1e-6));
    const std::int64_t dense_entries = static_cast<std::int64_t>(res + 1) * (res + 1) * (res + 1);
    const bool dense = dense_entries <= table;
    layout.resolution.push_back(res);
    layout.dense.push_back(dense ? 1 : 0);
    layout.offset.push_back(offset);
    layout.entries.push_back(dense ? dense_entries : table);
    offset += layout.entries.back();
  }
  layout.total_entries = offset;
  return layout;
}

void hashEncodeForward(const HashGridLayout& layout, const float* table, const float* positions, std::int64_t n,
                       float* out) {
  dispatch<Fwd>(layout.features, layout, table, positions, n, out);
}

void hashEncodeBackwardTable(const HashGridLayout& layout, const float* positions, std::int64_t n,
                             const float* grad_out, float* grad_table, int level_begin, int level_end,
                             std::uint8_t* touched) {
  const std::int64_t dims = layout.outputDims();
  for (int level = level_begin; level < level_end; ++level) {
    dispatch<BwdL>(layout.features, layout, positions, n, grad_out + level * layout.features, dims, grad_table,
                   level, touched);
  }
}

void hashEncodeBackwardLevel(const HashGridLayout& layout, const float* positions, std::int64_t n,
                             const float* grad, std::int64_t grad_stride, float* grad_table, int level,
                             std::uint8_t* touched) {
  dispatch<BwdL>(layout.features, layout, positions, n, grad, grad_stride, grad_table, level, touched);
}

void hashEncodeBackwardPositions(const HashGridLayout& layout, const float* table, const float* positions,
                                 std::int64_t n, const float* grad_out, float* grad_positions) {
  dispatch<BwdP>(layout.features, layout, table, positions, n, grad_out, grad_positions);
}

}  // namespace demnerf::nerf
