#include "demnerf/render/speckle_texture.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::render {

std::uint64_t hashMix(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d) {
  const auto mix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  std::uint64_t h = mix(a);
  h = mix(h ^ b);
  h = mix(h ^ c);
  return mix(h ^ d);
}

SpeckleTexture::SpeckleTexture(const SpeckleConfig& config) : config_(config) {
  if (!(config.cell > 0) || !std::isfinite(config.cell)) {
    throw core::Error("speckle: cell size must be a positive length, got " + std::to_string(config.cell));
  }
  if (!(config.min_radius > 0) || config.max_radius < config.min_radius || config.max_radius > 0.5) {
    throw core::Error("speckle: need 0 < min_radius <= max_radius <= 0.5 cells (blobs must stay "
                      "within reach of the 2x2x2 cells that are searched)");
  }
  // An irrational-looking shift keeps flat faces (often at round coordinates) from slicing
  // every blob at the same height.
  offset_ = Eigen::Vector3d(0.3819660113, 0.6180339887, 0.2360679775) * config.cell;
}

double SpeckleTexture::brightness(const Eigen::Vector3d& rest_position) const {
  const double cell = config_.cell;
  const Eigen::Vector3d p = (rest_position + offset_) / cell;  // lattice units
  // A blob of radius <= 0.5 centred anywhere in its cell reaches at most half a cell beyond
  // it, so only the 2x2x2 cells nearest to p can touch p.
  std::array<long long, 3> first;
  for (int a = 0; a < 3; ++a) {
    const double base = std::floor(p[a]);
    first[a] = static_cast<long long>(base) - (p[a] - base < 0.5 ? 1 : 0);
  }
  double darkness = 0.0;
  for (int dx = 0; dx < 2; ++dx) {
    for (int dy = 0; dy < 2; ++dy) {
      for (int dz = 0; dz < 2; ++dz) {
        const long long ci = first[0] + dx, cj = first[1] + dy, ck = first[2] + dz;
        const std::uint64_t h = hashMix(config_.seed, static_cast<std::uint64_t>(ci),
                                        static_cast<std::uint64_t>(cj), static_cast<std::uint64_t>(ck));
        if (hashUnit(h) >= config_.fill_probability) continue;
        const double radius = config_.min_radius +
            (config_.max_radius - config_.min_radius) * hashUnit(hashMix(h, 1));
        // The centre may sit anywhere in its cell (so that a plane at any height cuts as many
        // blobs as any other); the blob then pokes at most half a cell into the neighbours.
        const Eigen::Vector3d centre(ci + hashUnit(hashMix(h, 2)), cj + hashUnit(hashMix(h, 3)),
                                     ck + hashUnit(hashMix(h, 4)));
        const double distance = (p - centre).norm();
        if (distance >= radius) continue;
        const double inner = radius * (1.0 - config_.softness);
        double value = 1.0;
        if (distance > inner) {
          const double x = (radius - distance) / (radius - inner);  // 0 at the rim, 1 inside
          value = x * x * (3.0 - 2.0 * x);
        }
        darkness = std::max(darkness, value);
      }
    }
  }
  return 1.0 - config_.contrast * darkness;
}

SurfaceShader::SurfaceShader(const ShadingConfig& shading, const SpeckleConfig& speckle)
    : shading_(shading), speckle_(speckle),
      key_(shading.key_direction.normalized()), fill_(shading.fill_direction.normalized()) {}

Eigen::Vector3d SurfaceShader::shade(const Eigen::Vector3d& rest_position,
                                     const Eigen::Vector3d& rest_normal,
                                     const Eigen::Vector3d& normal) const {
  // Faces facing x lean red, y green, z blue: the sign is kept too, so opposite faces differ.
  const double t = shading_.orientation_tint;
  Eigen::Vector3d albedo = shading_.base_color;
  albedo += t * Eigen::Vector3d(rest_normal.x(), rest_normal.y(), rest_normal.z());
  albedo = albedo.cwiseMax(0.0).cwiseMin(1.0) * speckle_.brightness(rest_position);
  const double light = shading_.ambient + shading_.key * std::max(0.0, normal.dot(key_)) +
                       shading_.fill * std::max(0.0, normal.dot(fill_));
  return (albedo * light).cwiseMax(0.0).cwiseMin(1.0);
}

}  // namespace demnerf::render
