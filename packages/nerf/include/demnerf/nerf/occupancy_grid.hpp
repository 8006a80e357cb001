#pragma once
// Occupancy grid over the scene box: an exponential moving average of each cell's optical
// thickness and a bitfield of the cells worth sampling (instant-ngp's update schedule).

#include <cstdint>
#include <vector>

#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/field.hpp"

namespace demnerf::nerf {

class OccupancyGrid {
 public:
  OccupancyGrid() = default;
  /// min_step: the marcher's smallest step (m); thickness = density * min_step.
  OccupancyGrid(const OccupancyConfig& config, const Box& bounds, float min_step);

  int resolution() const { return resolution_; }
  std::int64_t cells() const { return static_cast<std::int64_t>(resolution_) * resolution_ * resolution_; }
  const Box& bounds() const { return bounds_; }

  bool occupied(std::int64_t cell) const { return (bits_[cell >> 3] >> (cell & 7)) & 1; }
  /// Cell of a world point, or -1 outside the box.
  std::int64_t cellOf(const float* point) const;
  double occupiedFraction() const;

  /// One scheduled update at training step `step` (call every update_interval steps):
  /// all cells during warm-up, then a quarter at random plus a quarter of the occupied ones.
  void update(const Field& field, std::int64_t step, std::uint64_t seed);
  /// Re-samples every cell `samples_per_cell` times without decay (after loading old weights).
  void rebuild(const Field& field, int samples_per_cell, std::uint64_t seed);
  void markAll();

  std::vector<float>& thickness() { return thickness_; }
  const std::vector<float>& thickness() const { return thickness_; }
  std::vector<std::uint8_t>& bits() { return bits_; }
  const std::vector<std::uint8_t>& bits() const { return bits_; }
  void refreshBits();

 private:
  void sampleCells(const Field& field, const std::vector<std::int64_t>& cells, std::uint64_t seed,
                   std::vector<float>& best) const;

  OccupancyConfig config_;
  Box bounds_;
  float min_step_ = 0.0f;
  int resolution_ = 0;
  std::vector<float> thickness_;
  std::vector<std::uint8_t> bits_;
};

}  // namespace demnerf::nerf
