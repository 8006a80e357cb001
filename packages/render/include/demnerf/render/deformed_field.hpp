#pragma once
// The deformed body as a radiance field: a point x of the deformed scene is mapped to its rest
// position X through the tetrahedral embedding and the NeRF is asked there. Outside the
// deformed body, or where the NeRF's own occupancy grid is empty (the undeformed marcher
// would skip it), the density is zero. Rendered through nerf::renderRays like the NeRF itself.

#include "demnerf/nerf/field.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/render/tet_embedding.hpp"

namespace demnerf::render {

class DeformedField : public nerf::Field {
 public:
  /// rotate_directions: turn the view direction by the local rotation of the deformation, so
  /// view-dependent colour follows the material. Holds references to model and embedding.
  DeformedField(const nerf::NerfModel& model, const TetEmbedding& embedding, const nerf::Box& bounds,
                bool rotate_directions);

  nerf::Box bounds() const override { return bounds_; }
  void density(const float* points, std::int64_t n, float* sigma) const override;
  void query(const float* points, const float* directions, std::int64_t n, float* sigma,
             float* rgb) const override;

 private:
  /// Density (and colour when rgb is set) of n <= kBlock points on the calling thread.
  void queryBlock(const float* points, const float* directions, int n, float* sigma, float* rgb) const;

  const nerf::NerfModel& model_;
  const TetEmbedding& embedding_;
  nerf::Box bounds_;
  bool rotate_;
};

}  // namespace demnerf::render
