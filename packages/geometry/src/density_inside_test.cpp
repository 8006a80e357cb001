#include "demnerf/geometry/density_inside_test.hpp"

#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/optical_depth.hpp"

namespace demnerf::geometry {
namespace {

void checkConfig(const DensityInsideConfig& config) {
  std::ostringstream problem;
  if (!std::isfinite(config.threshold)) {
    problem << "density inside test: threshold " << config.threshold << " must be a finite density";
  } else if (!(config.smoothing_radius >= 0) || !std::isfinite(config.smoothing_radius)) {
    problem << "density inside test: smoothing radius " << config.smoothing_radius << " must be >= 0 (metres)";
  }
  if (!problem.str().empty()) throw core::Error(problem.str());
}

// Stencil: centre weight 1/4, six axis neighbours 1/8 each. Its second moment along each axis
// is radius^2 / 4, a light blur that keeps a flat surface where it is.
constexpr int kStencil = 7;
constexpr double kCentreWeight = 0.25;
constexpr double kNeighbourWeight = 0.125;

}  // namespace

double sampleTrilinear(const DensityGrid& grid, const Eigen::Vector3d& p) {
  const Eigen::Vector3d u = (p - grid.origin).cwiseQuotient(grid.spacing);
  if (!u.allFinite()) return 0.0;
  int base[3];
  double frac[3];
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor(u[a]);
    // Beyond one cell outside the nodes everything is empty; the floor of a huge value must
    // not overflow the int.
    if (f < -1 || f > grid.dims[a] - 1) return 0.0;
    base[a] = static_cast<int>(f);
    frac[a] = u[a] - f;
  }
  auto value = [&](int i, int j, int k) -> double {
    if (i < 0 || j < 0 || k < 0 || i >= grid.dims.x() || j >= grid.dims.y() || k >= grid.dims.z()) return 0.0;
    return grid.at(i, j, k);
  };
  double sum = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double w = (di ? frac[0] : 1 - frac[0]) * (dj ? frac[1] : 1 - frac[1]) * (dk ? frac[2] : 1 - frac[2]);
    if (w != 0.0) sum += w * value(base[0] + di, base[1] + dj, base[2] + dk);
  }
  return sum;
}

DensityInsideTest DensityInsideTest::matchingExtraction(const DensityGrid& grid,
                                                        const MeshExtractionConfig& extraction) {
  DensityInsideConfig config;
  if (extraction.surface == SurfaceDefinition::kOpacity) {
    if (!(extraction.opacity > 0 && extraction.opacity < 1)) {
      throw core::Error("density inside test: opacity " + std::to_string(extraction.opacity) + " must be in (0, 1)");
    }
    config.threshold = -std::log(1.0 - extraction.opacity);
    return DensityInsideTest(axisOpticalDepth(grid), config);
  }
  config.threshold = extraction.threshold;
  return DensityInsideTest(grid, config);
}

DensityInsideTest::DensityInsideTest(DensityGrid grid, const DensityInsideConfig& config)
    : config_(config), grid_(std::move(grid)) {
  checkConfig(config_);
  grid_.validate("density inside test grid");
}

DensityInsideTest::DensityInsideTest(DensityFunction density, const DensityInsideConfig& config)
    : config_(config), function_(std::move(density)) {
  checkConfig(config_);
  if (!function_) throw core::Error("density inside test: the density function is empty");
}

void DensityInsideTest::rawDensity(const std::vector<float>& xyz, std::vector<float>& sigma) const {
  const std::int64_t n = static_cast<std::int64_t>(xyz.size() / 3);
  sigma.assign(static_cast<std::size_t>(n), 0.0f);
  if (n == 0) return;
  if (function_) {
    function_(xyz.data(), n, sigma.data());
    return;
  }
  for (std::int64_t i = 0; i < n; ++i) {
    sigma[i] = static_cast<float>(sampleTrilinear(grid_, Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2])));
  }
}

std::vector<float> DensityInsideTest::density(const std::vector<Eigen::Vector3d>& points) const {
  const bool smooth = config_.smoothing_radius > 0;
  const int per_point = smooth ? kStencil : 1;
  // One batched call for all stencil points: a NeRF evaluates large batches far faster.
  std::vector<float> xyz;
  xyz.reserve(points.size() * per_point * 3);
  const double r = config_.smoothing_radius;
  for (const auto& p : points) {
    auto push = [&](const Eigen::Vector3d& q) {
      for (int a = 0; a < 3; ++a) xyz.push_back(static_cast<float>(q[a]));
    };
    push(p);
    if (!smooth) continue;
    for (int a = 0; a < 3; ++a) {
      push(p + r * Eigen::Vector3d::Unit(a));
      push(p - r * Eigen::Vector3d::Unit(a));
    }
  }
  std::vector<float> sigma;
  rawDensity(xyz, sigma);
  if (!smooth) return sigma;
  std::vector<float> result(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float* s = sigma.data() + i * kStencil;
    double sum = kCentreWeight * s[0];
    for (int m = 1; m < kStencil; ++m) sum += kNeighbourWeight * s[m];
    result[i] = static_cast<float>(sum);
  }
  return result;
}

std::vector<std::uint8_t> DensityInsideTest::inside(const std::vector<Eigen::Vector3d>& points) const {
  const std::vector<float> sigma = density(points);
  std::vector<std::uint8_t> result(points.size());
  // NaN densities (a broken field) compare false: outside.
  for (std::size_t i = 0; i < points.size(); ++i) result[i] = sigma[i] > config_.threshold;
  return result;
}

bool DensityInsideTest::inside(const Eigen::Vector3d& point) const {
  return inside(std::vector<Eigen::Vector3d>{point})[0] != 0;
}

}  // namespace demnerf::geometry
