#include "demnerf/geometry/regions.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {

std::vector<std::size_t> selectParticles(const core::ParticleCloud& cloud, const core::Region& region,
                                         const std::string& what, ParticleKind kind) {
  if (!region.center.allFinite() || !region.size.allFinite() || !std::isfinite(region.radius) ||
      !region.normal.allFinite()) {
    throw core::Error(what + ": region " + region.describe() + " holds NaN or Inf");
  }
  std::vector<std::size_t> selected;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const bool surface = cloud.areas[i] > 0.0;
    if (kind == ParticleKind::kSurface && !surface) continue;
    if (kind == ParticleKind::kInterior && surface) continue;
    if (region.contains(cloud.positions[i])) selected.push_back(i);
  }
  if (selected.empty()) {
    const char* kind_name = kind == ParticleKind::kSurface ? "surface particles"
                            : kind == ParticleKind::kInterior ? "interior particles" : "particles";
    throw core::Error(what + " selects no " + kind_name + ": region " + region.describe() + " (the cloud has " +
                      std::to_string(cloud.size()) + " particles)");
  }
  return selected;
}

}  // namespace demnerf::geometry
