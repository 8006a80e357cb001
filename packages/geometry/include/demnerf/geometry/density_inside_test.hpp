#pragma once
// Point-in-body queries straight from a density field (the NeRF's), without a mesh: a point is
// inside when the density, averaged over a small neighbourhood, exceeds the extraction threshold.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "demnerf/geometry/density_grid.hpp"

namespace demnerf::geometry {

/// Batched density: sigma[n] at points[n x 3] (x y z interleaved, metres). The signature of
/// nerf::Field::density, so a NeRF plugs in as
/// `[&](const float* p, std::int64_t n, float* s) { model.field().density(p, n, s); }`
/// without packages/geometry linking packages/nerf (and torch).
using DensityFunction = std::function<void(const float* points, std::int64_t n, float* sigma)>;

/// Trilinear interpolation of the grid at p. Outside the grid's nodes the field is 0 (empty
/// space), the same convention extractIsoSurface uses to close the surface at the border.
double sampleTrilinear(const DensityGrid& grid, const Eigen::Vector3d& p);

struct DensityInsideConfig {
  /// Same meaning as MeshExtractionConfig::threshold, so the answer agrees with the mesh.
  double threshold = 2.5;
  /// Radius of the averaging stencil (m): the density is averaged over the point and the six
  /// points +-radius along each axis (weights 1/4 and 1/8 each), which suppresses the NeRF's
  /// single-sample spikes and pin-holes. 0 queries the point alone. For a grid, 0 is usual:
  /// trilinear interpolation already averages over one cell.
  double smoothing_radius = 0.0;
};

/// Inside test from density: either a DensityGrid (trilinear) or a DensityFunction (queried
/// directly, in batches). Thread-safety follows the function's: the grid form is read-only.
struct MeshExtractionConfig;

class DensityInsideTest {
 public:
  /// The inside test that agrees with extractMesh(grid, extraction): for a density surface,
  /// trilinear density > threshold; for an opacity surface, trilinear axisOpticalDepth(grid) >
  /// -ln(1 - opacity) (so the NeRF's unseen, often near-empty interior still counts as inside).
  static DensityInsideTest matchingExtraction(const DensityGrid& grid, const MeshExtractionConfig& extraction);

  /// Throws core::Error for an invalid grid or a threshold / radius that is NaN or negative.
  DensityInsideTest(DensityGrid grid, const DensityInsideConfig& config = {});
  DensityInsideTest(DensityFunction density, const DensityInsideConfig& config = {});

  /// Smoothed density at each point.
  std::vector<float> density(const std::vector<Eigen::Vector3d>& points) const;
  /// inside[i] != 0 when density(points[i]) > threshold.
  std::vector<std::uint8_t> inside(const std::vector<Eigen::Vector3d>& points) const;
  bool inside(const Eigen::Vector3d& point) const;

  const DensityInsideConfig& config() const { return config_; }

 private:
  void rawDensity(const std::vector<float>& xyz, std::vector<float>& sigma) const;

  DensityInsideConfig config_;
  DensityGrid grid_;
  DensityFunction function_;
};

}  // namespace demnerf::geometry
