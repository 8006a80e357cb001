#pragma once
// A trained (or training) NeRF: config, scene box, field weights and occupancy grid.

#include <memory>

#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/ngp_field.hpp"
#include "demnerf/nerf/occupancy_grid.hpp"
#include "demnerf/nerf/ray_marcher.hpp"

namespace demnerf::nerf {

class NerfModel {
 public:
  /// A fresh model (random weights from config.train.seed, every occupancy cell marked).
  NerfModel(const NerfConfig& config, const Box& bounds, double aabb_scale);

  const NerfConfig& config() const { return field_.config(); }
  Box bounds() const { return field_.bounds(); }
  double aabbScale() const { return field_.aabbScale(); }
  NgpField& field() { return field_; }
  const NgpField& field() const { return field_; }
  OccupancyGrid& grid() { return grid_; }
  const OccupancyGrid& grid() const { return grid_; }
  const MarchParams& march() const { return march_; }
  /// Marching for renders (coarser for unbounded scenes; see MarchConfig::render_cone_angle).
  const MarchParams& renderMarch() const { return render_march_; }

  /// Density sampled at the centres of a res x res x res lattice over the box, x fastest
  /// (for marching cubes). Threaded.
  std::vector<float> densityGrid(int resolution) const;

 private:
  NgpField field_;
  OccupancyGrid grid_;
  MarchParams march_;
  MarchParams render_march_;
};

}  // namespace demnerf::nerf
