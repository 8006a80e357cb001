#pragma once
// A speckle pattern (as in digital image correlation) attached to material points, and the
// Lambertian shading that turns it into a colour.

#include <Eigen/Core>
#include <cstdint>

namespace demnerf::render {

/// Dark blobs scattered on a 3D lattice: one blob per cell, at a hashed position and radius.
/// A function of the REST position, so a deformed body carries the same pattern.
struct SpeckleConfig {
  double cell = 0.01;            ///< lattice spacing (m)
  double min_radius = 0.22;      ///< blob radius range, in cells (at most 0.5)
  double max_radius = 0.42;
  double fill_probability = 0.75;  ///< share of cells that hold a blob
  double softness = 0.35;        ///< width of the blob's soft rim, as a share of its radius
  double contrast = 0.7;         ///< how much a blob darkens the albedo (0..1)
  std::uint64_t seed = 1;
};

class SpeckleTexture {
 public:
  explicit SpeckleTexture(const SpeckleConfig& config);
  /// Brightness factor in [1 - contrast, 1] at a rest position.
  double brightness(const Eigen::Vector3d& rest_position) const;
  const SpeckleConfig& config() const { return config_; }

 private:
  SpeckleConfig config_;
  Eigen::Vector3d offset_;  ///< lattice shift, so that the object's faces do not align with cell walls
};

/// Fixed lights in the world frame (a key light from above and a weaker fill from below) and
/// an albedo that depends a little on the rest face orientation, so that faces read apart.
struct ShadingConfig {
  Eigen::Vector3d base_color{0.8, 0.6, 0.4};
  Eigen::Vector3d key_direction{0.45, -0.35, 0.82};   ///< towards the light, normalised on use
  Eigen::Vector3d fill_direction{-0.55, 0.60, -0.35};
  double ambient = 0.40;
  double key = 0.65;
  double fill = 0.25;
  double orientation_tint = 0.10;  ///< colour shift per rest-normal axis
};

class SurfaceShader {
 public:
  SurfaceShader(const ShadingConfig& shading, const SpeckleConfig& speckle);
  /// Linear RGB in [0, 1] of the material point at `rest_position` whose face had unit normal
  /// `rest_normal` before deformation and has unit normal `normal` now.
  Eigen::Vector3d shade(const Eigen::Vector3d& rest_position, const Eigen::Vector3d& rest_normal,
                        const Eigen::Vector3d& normal) const;

 private:
  ShadingConfig shading_;
  SpeckleTexture speckle_;
  Eigen::Vector3d key_, fill_;
};

/// A 64-bit mix of the inputs (splitmix64 finaliser): the one source of randomness here, so
/// that the same seed always gives the same scene.
std::uint64_t hashMix(std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0, std::uint64_t d = 0);
/// Uniform in [0, 1) from a hash.
inline double hashUnit(std::uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

}  // namespace demnerf::render
