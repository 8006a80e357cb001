#pragma once
// Ray casting of a (possibly deformed) textured triangle mesh into RGBA images with coverage alpha.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <opencv2/core.hpp>

#include "demnerf/core/camera.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/ray.hpp"
#include "demnerf/render/speckle_texture.hpp"

namespace demnerf::render {

struct RenderConfig {
  /// Stratified, jittered samples per pixel axis (4 -> 16 samples). Deterministic for a seed.
  int samples_per_axis = 4;
  /// Cast a 2x2 pattern first and take all samples only where it sees an edge (silhouette,
  /// crease or depth step); same result inside faces, several times faster.
  bool adaptive = true;
  int threads = 0;  ///< 0: all cores
  std::uint64_t seed = 0;
};

/// Where a ray meets the surface.
struct SurfaceHit {
  double distance = 0.0;      ///< along the (unit) ray direction
  int face = -1;
  Eigen::Vector3d point;      ///< in the deformed (rendered) mesh
  Eigen::Vector3d rest_point; ///< the same material point before deformation (same barycentrics)
  Eigen::Vector3d normal;     ///< deformed face normal, facing the ray's origin
  Eigen::Vector3d rest_normal;///< outward normal of the face at rest
};

/// Ray caster over a CGAL AABB tree of the deformed mesh's triangles. The rest mesh (same
/// faces) carries the texture: a hit's barycentrics map it back to its material point.
class MeshRenderer {
 public:
  /// An undeformed object.
  MeshRenderer(const core::TriangleMesh& mesh, const SurfaceShader& shader);
  /// `deformed` must have the rest mesh's faces and vertex count (throws core::Error otherwise).
  MeshRenderer(const core::TriangleMesh& rest, const core::TriangleMesh& deformed, const SurfaceShader& shader);
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// The nearest hit along the ray, if any. Thread-safe.
  std::optional<SurfaceHit> castRay(const core::Ray& ray) const;

  /// RGBA image (CV_32FC4, straight alpha = share of samples that hit the object; colour =
  /// mean colour of those samples; transparent black background).
  cv::Mat render(const core::PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                 const RenderConfig& config = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::render
