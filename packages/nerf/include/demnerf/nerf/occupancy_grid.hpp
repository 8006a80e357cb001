#pragma once
// Occupancy grid over the scene box: an exponential moving average of each cell's optical
// thickness and a bitfield of the cells worth sampling (instant-ngp's update schedule).
//
// For unbounded captures (aabb_scale > 1) the grid is a set of cascades, as in instant-ngp:
// nested grids of the same resolution around the box centre, each twice the extent of the one
// inside it, so cells near the object are small and cells far away are large. A point belongs
// to the smallest cascade that holds it; the cells of a cascade that an inner one covers are
// never used. Cells no training camera sees are kept empty (the field is unconstrained there).

#include <cstdint>
#include <vector>

#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/field.hpp"

namespace demnerf::nerf {

/// A training camera as the visibility test needs it (pinhole, optical frame, row-major R).
struct GridCamera {
  float rotation[9];  ///< world_from_camera
  float origin[3];
  float fx, fy, cx, cy;
  int width, height;
};

class OccupancyGrid {
 public:
  OccupancyGrid() = default;
  /// min_step: the marcher's smallest step (m); thickness = density * min_step. `cascades`
  /// nested grids (>= 1); the outermost spans `bounds`.
  OccupancyGrid(const OccupancyConfig& config, const Box& bounds, float min_step, int cascades = 1);

  int resolution() const { return resolution_; }
  int cascades() const { return cascades_; }
  std::int64_t cellsPerCascade() const { return static_cast<std::int64_t>(resolution_) * resolution_ * resolution_; }
  std::int64_t cells() const { return cascades_ * cellsPerCascade(); }
  /// The outermost cascade's box (the whole scene box).
  const Box& bounds() const { return bounds_; }
  /// The box of cascade k (0 innermost).
  Box cascadeBox(int k) const;
  /// Smallest cell edge of cascade k (m).
  float cellSize(int k) const { return min_cell_ * static_cast<float>(1 << k); }

  bool occupied(std::int64_t cell) const { return (bits_[cell >> 3] >> (cell & 7)) & 1; }
  /// The smallest cascade holding a world point, or -1 outside the box.
  int cascadeOf(const float* point) const;
  /// Cell (cascade-major index) of a world point, or -1 outside the box.
  std::int64_t cellOf(const float* point) const;
  /// Parameter t where a ray from `origin` along `direction` leaves the cell of cascade k that
  /// holds `point` (a point on the ray).
  float cellExit(int k, const float* point, const float* origin, const float* inv_direction) const;
  /// Whether any cell overlapping the world box [lo, hi] is occupied (any cascade).
  bool anyOccupied(const float* lo, const float* hi) const;
  /// Fraction of the used cells (seen, not covered by an inner cascade) that are occupied.
  double occupiedFraction() const;

  /// One scheduled update at training step `step` (call every update_interval steps):
  /// all cells during warm-up, then a quarter at random plus a quarter of the occupied ones.
  void update(const Field& field, std::int64_t step, std::uint64_t seed);
  /// Re-samples every cell `samples_per_cell` times without decay (after loading old weights).
  void rebuild(const Field& field, int samples_per_cell, std::uint64_t seed);
  void markAll();
  /// Keeps empty every cell that none of the cameras sees (no camera frustum holds any of it);
  /// an empty list marks every cell seen. Threaded.
  void setVisibility(const std::vector<GridCamera>& cameras);

  std::vector<float>& thickness() { return thickness_; }
  const std::vector<float>& thickness() const { return thickness_; }
  std::vector<std::uint8_t>& bits() { return bits_; }
  const std::vector<std::uint8_t>& bits() const { return bits_; }
  void refreshBits();

 private:
  void sampleCells(const Field& field, const std::vector<std::int64_t>& cells, std::uint64_t seed,
                   std::vector<float>& best) const;
  void cellCentre(std::int64_t cell, float* centre) const;
  void markCovered();

  OccupancyConfig config_;
  Box bounds_;
  float centre_[3] = {0, 0, 0}, half_[3] = {0.5f, 0.5f, 0.5f};  ///< of the outermost box
  float min_cell_ = 0.0f;  ///< cascade 0's smallest cell edge
  float min_step_ = 0.0f;
  int resolution_ = 0;
  int cascades_ = 1;
  std::vector<float> thickness_;
  std::vector<std::uint8_t> bits_;
  std::vector<std::uint8_t> used_;  ///< 1: seen by a camera and not covered by an inner cascade
};

/// Cascades for a scene of extent hint aabb_scale: 1 + log2(aabb_scale) rounded up (instant-ngp),
/// or the config's count when it is > 0.
int cascadeCount(const OccupancyConfig& config, double aabb_scale);

}  // namespace demnerf::nerf
