#pragma once
// Particle clouds that discretise a body bounded by a closed mesh: the paper's three samplers.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

enum class SamplingMethod {
  kRandom,   ///< uniform in the bounding box, kept if inside (the paper's Eq. randomSample)
  kPoisson,  ///< Bridson's Poisson disk in 3D: every pair of particles at least `spacing` apart
  kGrid,     ///< a regular grid with `spacing` on each axis (the paper's Eq. uniformedMeshSample)
};

/// "random" | "poisson" | "grid"; throws core::Error listing the choices otherwise.
SamplingMethod parseSamplingMethod(const std::string& name);
const char* samplingMethodName(SamplingMethod method);

/// How interior particles get their volume weight.
enum class VolumeWeights {
  kVoronoi,  ///< the particle's Voronoi cell clipped to the body (measured on a fine lattice)
  kUniform,  ///< body volume / particle count (the Monte Carlo weight)
};

/// Colour of the object at a point, RGB in [0, 1] (e.g. a NeRF's radiance).
using ColorFunction = std::function<Eigen::Vector3d(const Eigen::Vector3d& point)>;

struct SamplerConfig {
  SamplingMethod method = SamplingMethod::kPoisson;
  /// Particle spacing h (m). random: about volume / h^3 interior and area / h^2 surface
  /// particles; poisson: the minimum distance r; grid: the grid step.
  double spacing = 0.0;
  std::uint64_t seed = 1;
  VolumeWeights volume_weights = VolumeWeights::kVoronoi;
  /// Fine-lattice points per spacing along each axis, for Voronoi volumes (3 -> 27 per particle).
  int voronoi_resolution = 3;
  int poisson_attempts = 30;  ///< Bridson's k: candidates tried around each active particle
  bool surface = true;        ///< also place surface particles (normal + area)
  /// false: only interior particles carry volume (they sum to the body's volume) and surface
  /// particles have volume 0. true: surface particles take their Voronoi share too, and the
  /// volumes of all particles sum to the body's. Poisson keeps interior particles r away from
  /// the surface, so with false their cells reach to the surface and volume integrals lean
  /// inward (about 6 % on the second moment of a unit cube at r = 0.08); true removes that.
  bool surface_volumes = false;
  /// Fewer interior particles than this means the spacing is too large for the body.
  std::size_t min_interior_particles = 8;
  /// More particles than this means the spacing is too small for this machine.
  std::size_t max_particles = 20'000'000;
  ColorFunction color;  ///< unset: grey
};

/// What a sampler produced besides the cloud.
struct SamplingReport {
  std::size_t interior = 0;
  std::size_t surface = 0;
  double mesh_volume = 0.0;
  double mesh_area = 0.0;
  double volume_sum = 0.0;  ///< sum of particle volumes
  double area_sum = 0.0;    ///< sum of particle areas
  /// Surface points dropped because the half-ball of one spacing in front of them is mostly
  /// solid (a crack or thin cavity of a NeRF extraction the cloud cannot resolve); their area is
  /// not in area_sum.
  std::size_t crack_walls = 0;
};

/// Samples the body bounded by `mesh` (closed; faces may point in or out, they are turned
/// outward). Interior particles come first, with volume > 0 and area 0, their volumes summing to
/// the mesh volume; surface particles follow, on the mesh, with volume 0 (see surface_volumes),
/// the outward unit normal of their patch (the mean of the faces within half a spacing and 60 deg of
/// theirs: a flat face's normal, a bumpy one's averaged) and an area weight, the areas summing to
/// the mesh area less that of crack walls (SamplingReport::crack_walls; exact surfaces have none). Deterministic
/// for a given seed. Throws core::Error for an open/empty/degenerate mesh, a spacing that is
/// not positive, too large for the body or so small the cloud would exceed max_particles.
core::ParticleCloud sampleParticles(const core::TriangleMesh& mesh, const SamplerConfig& config,
                                    SamplingReport* report = nullptr);

/// The grid the kGrid sampler uses for a body with these bounds: n_k = ceil(extent_k / h)
/// nodes per axis (at least 1), spaced exactly h and centred in the box, i.e. the paper's
/// x_i = a + (i - 1)(b - a)/(N - 1) on the box shrunk so that its nodes are cell centres.
struct GridLayout {
  Eigen::Vector3d origin;
  double spacing;
  Eigen::Vector3i dims;
};
GridLayout gridLayout(const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max, double spacing);

}  // namespace demnerf::geometry
