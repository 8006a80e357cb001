#include <algorithm>
#include <cstdint>
#if defined(__AVX512F__) && defined(__F16C__)
#include <immintrin.h>
#define DEMNERF_HALF_TABLE 1
#endif

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/hash_encoding.hpp"
#include "hash_level_run.hpp"

// The hash encoding's forward from a half-precision copy of the table. The fine levels'
// gathers are bound by cache misses (a 2^16-entry level is 512 KiB in floats and the 13
// hashed levels do not stay in L2), so halving an entry to 4 bytes halves the lines they
// wait on, and one 32-bit gather fetches a corner for 16 points instead of 8. The float
// table stays the master copy that Adam updates; the forward sees it rounded to 11 bits.

namespace demnerf::nerf {

#if defined(DEMNERF_HALF_TABLE)
namespace {

using detail::kRun;
using detail::LevelRun;

// Corner k of 16 points per gather; lanes 2p, 2p+1 of a converted half-vector are point p's
// two features, so point p's weight is duplicated into both. Returns the points done (a
// multiple of 16); the caller's scalar loop takes the rest.
inline int gatherHalfPairs(const std::uint16_t* level_half, const LevelRun& run, int m, float* out, int dims) {
  const __m512i dup_lo = _mm512_set_epi32(7, 7, 6, 6, 5, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0);
  const __m512i dup_hi = _mm512_set_epi32(15, 15, 14, 14, 13, 13, 12, 12, 11, 11, 10, 10, 9, 9, 8, 8);
  int i = 0;
  for (; i + 16 <= m; i += 16) {
    __m512 lo = _mm512_setzero_ps(), hi = _mm512_setzero_ps();
    for (int k = 0; k < 8; ++k) {
      const __m512i idx = _mm512_load_si512(reinterpret_cast<const void*>(&run.index[k][i]));
      const __m512i pairs = _mm512_i32gather_epi32(idx, level_half, 4);
      const __m512 w = _mm512_load_ps(&run.weight[k][i]);
      lo = _mm512_fmadd_ps(_mm512_permutexvar_ps(dup_lo, w), _mm512_cvtph_ps(_mm512_castsi512_si256(pairs)), lo);
      hi = _mm512_fmadd_ps(_mm512_permutexvar_ps(dup_hi, w), _mm512_cvtph_ps(_mm512_extracti64x4_epi64(pairs, 1)),
                           hi);
    }
    alignas(64) float lanes[32];
    _mm512_store_ps(lanes, lo);
    _mm512_store_ps(lanes + 16, hi);
    for (int p = 0; p < 16; ++p) {
      out[(i + p) * dims] = lanes[2 * p];
      out[(i + p) * dims + 1] = lanes[2 * p + 1];
    }
  }
  return i;
}

}  // namespace

bool halfTableSupported() { return true; }

void hashEncodeForwardHalf(const HashGridLayout& layout, const std::uint16_t* half, const float* positions,
                           std::int64_t n, float* out) {
  if (layout.features != 2) {
    throw core::Error("hash encoding: the half-precision table needs 2 features per level, got " +
                      std::to_string(layout.features));
  }
  const int dims = layout.levels * 2;
  thread_local LevelRun run;
  for (std::int64_t first = 0; first < n; first += kRun) {
    const int m = static_cast<int>(std::min<std::int64_t>(kRun, n - first));
    float* o = out + first * dims;
    for (int level = 0; level < layout.levels; ++level) {
      const std::uint16_t* level_half = half + layout.offset[level] * 2;
      detail::levelRun(layout, level, positions + 3 * first, m, run);
      if (!layout.dense[level]) {
        for (int k = 0; k < 8; k += 2)  // x-neighbours (k, k+1) usually share a cache line
          for (int i = 0; i < m; ++i) __builtin_prefetch(level_half + static_cast<std::size_t>(run.index[k][i]) * 2);
      }
      for (int i = gatherHalfPairs(level_half, run, m, o + level * 2, dims); i < m; ++i) {
        float a0 = 0.0f, a1 = 0.0f;
        for (int k = 0; k < 8; ++k) {
          const std::uint16_t* entry = level_half + static_cast<std::size_t>(run.index[k][i]) * 2;
          a0 += run.weight[k][i] * _cvtsh_ss(entry[0]);
          a1 += run.weight[k][i] * _cvtsh_ss(entry[1]);
        }
        o[i * dims + level * 2] = a0;
        o[i * dims + level * 2 + 1] = a1;
      }
    }
  }
}

void toHalf(const float* values, std::int64_t begin, std::int64_t end, std::uint16_t* half) {
  std::int64_t i = begin;
  for (; i + 16 <= end; i += 16) {
    const __m256i h = _mm512_cvtps_ph(_mm512_loadu_ps(values + i), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(half + i), h);
  }
  for (; i < end; ++i) half[i] = _cvtss_sh(values[i], _MM_FROUND_TO_NEAREST_INT);
}

#else

bool halfTableSupported() { return false; }

void hashEncodeForwardHalf(const HashGridLayout&, const std::uint16_t*, const float*, std::int64_t, float*) {
  throw core::Error("hash encoding: this build has no half-precision forward (needs AVX-512 and F16C)");
}

void toHalf(const float*, std::int64_t, std::int64_t, std::uint16_t*) {}

#endif

}  // namespace demnerf::nerf
