#pragma once
// A trained (or training) NeRF: config, scene box, field weights and occupancy grid. Renderers,
// the occupancy grid and surface extraction see the field through the Field interface; only
// the trainer and the model files reach its instant-NGP weights and kernels.

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

  const NerfConfig& config() const { return ngp_.config(); }
  Box bounds() const { return field().bounds(); }
  double aabbScale() const { return ngp_.aabbScale(); }
  /// The radiance field: density and colour at points (rendering, occupancy, extraction).
  const Field& field() const { return ngp_; }
  /// The field's trainable form: hash table, MLP weights and the chunk kernels of training
  /// (the trainer and the model files; call refreshTransposed() after writing weights).
  NgpField& ngp() { return ngp_; }
  const NgpField& ngp() const { return ngp_; }
  OccupancyGrid& grid() { return grid_; }
  const OccupancyGrid& grid() const { return grid_; }
  const MarchParams& march() const { return march_; }
  /// Marching for renders (coarser for unbounded scenes; see MarchConfig::render_cone_angle).
  const MarchParams& renderMarch() const { return render_march_; }

  /// Density sampled at the centres of a res x res x res lattice over the box, x fastest
  /// (for marching cubes). Threaded.
  std::vector<float> densityGrid(int resolution) const;

 private:
  // Held by value: a snapshot copies the model, and the trainer needs the concrete kernels.
  NgpField ngp_;
  OccupancyGrid grid_;
  MarchParams march_;
  MarchParams render_march_;
};

}  // namespace demnerf::nerf
