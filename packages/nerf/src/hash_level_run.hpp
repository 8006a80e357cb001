#pragma once
// Private to the hash-encoding kernels (hash_encoding.cpp, hash_encoding_half.cpp): the corner
// indices and trilinear weights of one level for a run of points.

#include <algorithm>
#include <cstdint>

#include "demnerf/nerf/hash_encoding.hpp"

namespace demnerf::nerf::detail {

// instant-ngp's spatial hash primes (the first is 1 so neighbouring x share cache lines).
constexpr std::uint32_t kPrime1 = 2654435761u;
constexpr std::uint32_t kPrime2 = 805459861u;

// Corner indices and weights of one level for a run of points, structure-of-arrays so the
// compiler vectorises across points; index[k][i], weight[k][i] for corner k of point i.
constexpr int kRun = 256;
struct LevelRun {
  alignas(64) std::uint32_t index[8][kRun];
  alignas(64) float weight[8][kRun];
};

inline void levelRun(const HashGridLayout& layout, int level, const float* positions, int n, LevelRun& run) {
  const int res = layout.resolution[level];
  const float scale = static_cast<float>(res);
  const bool dense = layout.dense[level];
  const std::uint32_t stride = static_cast<std::uint32_t>(res) + 1;
  const std::uint32_t mask = layout.hash_mask;
  for (int i = 0; i < n; ++i) {
    std::uint32_t c[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
      const float x = std::min(std::max(positions[3 * i + a], 0.0f), 1.0f) * scale;
      const int cell = std::min(static_cast<int>(x), res - 1);
      c[a] = static_cast<std::uint32_t>(cell);
      f[a] = x - static_cast<float>(cell);
    }
    const float wx0 = 1.0f - f[0], wy0 = 1.0f - f[1], wz0 = 1.0f - f[2];
    run.weight[0][i] = wx0 * wy0 * wz0;
    run.weight[1][i] = f[0] * wy0 * wz0;
    run.weight[2][i] = wx0 * f[1] * wz0;
    run.weight[3][i] = f[0] * f[1] * wz0;
    run.weight[4][i] = wx0 * wy0 * f[2];
    run.weight[5][i] = f[0] * wy0 * f[2];
    run.weight[6][i] = wx0 * f[1] * f[2];
    run.weight[7][i] = f[0] * f[1] * f[2];
    std::uint32_t y0, y1, z0, z1;
    if (dense) {
      y0 = c[1] * stride;
      y1 = y0 + stride;
      z0 = c[2] * stride * stride;
      z1 = z0 + stride * stride;
      run.index[0][i] = c[0] + y0 + z0;
      run.index[1][i] = c[0] + 1 + y0 + z0;
      run.index[2][i] = c[0] + y1 + z0;
      run.index[3][i] = c[0] + 1 + y1 + z0;
      run.index[4][i] = c[0] + y0 + z1;
      run.index[5][i] = c[0] + 1 + y0 + z1;
      run.index[6][i] = c[0] + y1 + z1;
      run.index[7][i] = c[0] + 1 + y1 + z1;
    } else {
      y0 = c[1] * kPrime1;
      y1 = (c[1] + 1) * kPrime1;
      z0 = c[2] * kPrime2;
      z1 = (c[2] + 1) * kPrime2;
      run.index[0][i] = (c[0] ^ y0 ^ z0) & mask;
      run.index[1][i] = ((c[0] + 1) ^ y0 ^ z0) & mask;
      run.index[2][i] = (c[0] ^ y1 ^ z0) & mask;
      run.index[3][i] = ((c[0] + 1) ^ y1 ^ z0) & mask;
      run.index[4][i] = (c[0] ^ y0 ^ z1) & mask;
      run.index[5][i] = ((c[0] + 1) ^ y0 ^ z1) & mask;
      run.index[6][i] = (c[0] ^ y1 ^ z1) & mask;
      run.index[7][i] = ((c[0] + 1) ^ y1 ^ z1) & mask;
    }
  }
}

}  // namespace demnerf::nerf::detail
