#pragma once
// Renders a NeRF's object deformed by a simulation result: every ray sample x in the deformed
// scene is mapped back to its rest position X through a tetrahedral embedding of the body and
// the NeRF is asked there; outside the deformed body the density is zero.

#include <Eigen/Geometry>
#include <memory>

#include "demnerf/core/camera.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/nerf/model.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "demnerf/render/deformed_field.hpp"
#include "demnerf/render/tet_embedding.hpp"

namespace demnerf::render {

struct DeformedRenderConfig {
  TetEmbeddingConfig embedding;
  /// Turn the view direction by the local rotation of the deformation for the colour query,
  /// so view-dependent colour follows the material (measured by bench/render_deformed_bench).
  bool rotate_directions = true;
  /// The result must have this many particles (the particle cloud it was computed on); 0: any.
  std::size_t expected_particles = 0;
  /// Refuse a result when fewer of its rest positions than this share lie where the NeRF's
  /// occupancy grid has density: it was computed on another body (or in another frame).
  double min_occupied_share = 0.5;
};

/// The deformed body, ready to render from any camera: the embedding, the deformed scene as a
/// Field, and an occupancy grid of the deformed scene (rasterised deformed tetrahedra whose
/// rest region the NeRF occupies). Holds a reference to the model, which must outlive it; not
/// copyable (its field refers to its embedding).
class DeformedScene {
 public:
  /// Throws core::Error when the result does not fit the model: empty, non-finite, wrong
  /// particle count, rest positions outside the model's box or where the NeRF is empty.
  DeformedScene(const nerf::NerfModel& model, const core::ResultField& result,
                const DeformedRenderConfig& config = {});
  DeformedScene(const DeformedScene&) = delete;
  DeformedScene& operator=(const DeformedScene&) = delete;

  const nerf::NerfModel& model() const { return model_; }
  const TetEmbedding& embedding() const { return embedding_; }
  const nerf::OccupancyGrid& grid() const { return grid_; }
  const nerf::Box& bounds() const { return grid_.bounds(); }
  const DeformedRenderConfig& config() const { return config_; }
  /// x -> X through the embedding, then the NeRF.
  const DeformedField& field() const { return *field_; }
  /// The undeformed renderer's marching over the deformed scene's grid and box.
  nerf::MarchScene marchScene() const;

 private:
  const nerf::NerfModel& model_;
  DeformedRenderConfig config_;
  TetEmbedding embedding_;
  nerf::OccupancyGrid grid_;
  std::unique_ptr<DeformedField> field_;
};

/// world_from_camera is the optical frame (z forward, y down); background RGB in [0, 1].
/// Threaded over rays with torch's thread count.
nerf::RenderedImage renderDeformed(const DeformedScene& scene, const core::PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background);
/// The same over the model's configured background.
nerf::RenderedImage renderDeformed(const DeformedScene& scene, const core::PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera);

}  // namespace demnerf::render
