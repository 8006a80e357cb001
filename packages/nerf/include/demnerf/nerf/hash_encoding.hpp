#pragma once
// Multiresolution hash encoding (instant-ngp): per level, trilinear interpolation of feature
// vectors stored at grid vertices, in a dense table when the level fits, else a spatial hash.

#include <cstdint>
#include <vector>

#include "demnerf/nerf/config.hpp"

namespace demnerf::nerf {

/// Where each level lives in the flat parameter table (entries of `features` floats each).
struct HashGridLayout {
  int levels = 0;
  int features = 0;
  std::uint32_t hash_mask = 0;             ///< table size - 1 (hashed levels)
  std::vector<int> resolution;             ///< cells per axis of each level
  std::vector<std::int64_t> offset;        ///< first entry of each level
  std::vector<std::int64_t> entries;       ///< entries of each level
  std::vector<char> dense;                 ///< level indexed densely ((res+1)^3 <= table size)
  std::int64_t total_entries = 0;

  /// finest_resolution 0 means 512 * aabb_scale.
  static HashGridLayout make(const HashGridConfig& config, double aabb_scale = 1.0);
  int outputDims() const { return levels * features; }
  std::int64_t parameterCount() const { return total_entries * features; }
};

// Raw float32 kernels on one thread; callers split the points between threads.
// Positions are n x 3, in [0, 1]^3 (clamped); outputs are n x (levels * features).

void hashEncodeForward(const HashGridLayout& layout, const float* table, const float* positions,
                       std::int64_t n, float* out);
/// Adds d(loss)/d(table) for the levels [level_begin, level_end). Levels own disjoint table
/// ranges, so threads that take different levels never write the same entry. When
/// `touched` is non-null, every entry written is flagged.
void hashEncodeBackwardTable(const HashGridLayout& layout, const float* positions, std::int64_t n,
                             const float* grad_out, float* grad_table, int level_begin, int level_end,
                             std::uint8_t* touched = nullptr);
/// Adds d(loss)/d(table) of one level; sample i's `features` gradient floats are read at
/// grad + i * grad_stride (levels * features for the n x outputDims() encoding gradient,
/// features for a level-major copy, which streams instead of striding).
void hashEncodeBackwardLevel(const HashGridLayout& layout, const float* positions, std::int64_t n,
                             const float* grad, std::int64_t grad_stride, float* grad_table, int level,
                             std::uint8_t* touched = nullptr);
/// Whether this build has the half-precision forward (AVX-512 and F16C, i.e. the kernels were
/// compiled for a CPU that has them); without it callers keep to the float table.
bool halfTableSupported();
/// The forward from a half-precision copy of a two-feature table (IEEE halves, two per entry,
/// entry e at half[2e]): the fine levels' gathers miss the cache on half the bytes. Needs
/// layout.features == 2 and halfTableSupported().
void hashEncodeForwardHalf(const HashGridLayout& layout, const std::uint16_t* half, const float* positions,
                           std::int64_t n, float* out);
/// Rounds floats [begin, end) of the table to the nearest half (no-op without support).
void toHalf(const float* values, std::int64_t begin, std::int64_t end, std::uint16_t* half);
/// Writes d(loss)/d(positions) (n x 3), positions in the unit cube.
void hashEncodeBackwardPositions(const HashGridLayout& layout, const float* table, const float* positions,
                                 std::int64_t n, const float* grad_out, float* grad_positions);

}  // namespace demnerf::nerf
