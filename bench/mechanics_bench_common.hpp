#pragma once
// What the mechanics benchmarks share: the T-bar of `demnerf synth --scene tbar` as particles and
// as a surface, and small timing helpers.

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/box_particles.hpp"

namespace demnerf::bench {

/// The mechanics benches' key=value arguments (words without '=' are ignored).
inline std::map<std::string, std::string> keyValueArguments(int argc, char** argv) {
  std::map<std::string, std::string> a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto eq = s.find('=');
    if (eq != std::string::npos) a[s.substr(0, eq)] = s.substr(eq + 1);
  }
  return a;
}

using Eigen::Vector3d;
namespace core = demnerf::core;

/// Leg 0.06 x 0.06 x 0.24 on z = 0, bar 0.30 x 0.06 x 0.06 on top.
inline bool inTbar(const Eigen::Vector3d& p) {
  const bool leg = std::abs(p.x()) < 0.03 && std::abs(p.y()) < 0.03 && p.z() > 0 && p.z() < 0.24;
  const bool bar = std::abs(p.x()) < 0.15 && std::abs(p.y()) < 0.03 && p.z() >= 0.24 && p.z() < 0.30;
  return leg || bar;
}

// Midpoint-rule particles of the T-bar on cells of size h (h must divide 0.03 and 0.06): one
// interior particle per cell, one surface particle per boundary cell face (area h^2, volume 0).
inline core::ParticleCloud tbarParticles(double h) {
  core::ParticleCloud cloud;
  const Vector3d lo(-0.15, -0.03, 0.0);
  const Eigen::Vector3i n(static_cast<int>(std::lround(0.30 / h)), static_cast<int>(std::lround(0.06 / h)),
                          static_cast<int>(std::lround(0.30 / h)));
  auto centre = [&](int i, int j, int k) -> Vector3d { return lo + h * Vector3d(i + 0.5, j + 0.5, k + 0.5); };
  for (int k = 0; k < n(2); ++k)
    for (int j = 0; j < n(1); ++j)
      for (int i = 0; i < n(0); ++i) {
        const Vector3d c = centre(i, j, k);
        if (!inTbar(c)) continue;
        cloud.append(c, h * h * h, Vector3d::Zero(), 0.0);
        for (int a = 0; a < 3; ++a)
          for (int s : {-1, 1}) {
            Vector3d d = Vector3d::Zero();
            d(a) = s;
            if (!inTbar(c + h * d)) cloud.append(c + 0.5 * h * d, 0.0, d, h * h);
          }
      }
  return cloud;
}

/// `count` points drawn uniformly inside the T-bar (rejection from its box), for prediction timings.
inline std::vector<Vector3d> pointsInTbar(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-0.15, 0.15), uy(-0.03, 0.03), uz(0.0, 0.30);
  std::vector<Vector3d> points;
  while (points.size() < count) {
    const Vector3d p(ux(rng), uy(rng), uz(rng));
    if (inTbar(p)) points.push_back(p);
  }
  return points;
}

/// The closed surface of the T-bar (leg and bar as two touching boxes: the ray-parity voxeliser
/// only looks at cell centres, which never lie on the shared face for these cell sizes).
inline core::TriangleMesh tbarSurface() {
  core::TriangleMesh surface = mechanics::boxSurface(Vector3d(-0.03, -0.03, 0.0), Vector3d(0.03, 0.03, 0.24));
  const core::TriangleMesh bar = mechanics::boxSurface(Vector3d(-0.15, -0.03, 0.24), Vector3d(0.15, 0.03, 0.30));
  const int offset = static_cast<int>(surface.vertices.size());
  for (const auto& f : bar.faces) surface.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
  surface.vertices.insert(surface.vertices.end(), bar.vertices.begin(), bar.vertices.end());
  return surface;
}

/// ||u - reference|| / ||reference|| over the points (the benches' displacement error).
inline double relativeL2(const std::vector<Vector3d>& u, const std::vector<Vector3d>& reference) {
  double e = 0.0, r = 0.0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    e += (u[i] - reference[i]).squaredNorm();
    r += reference[i].squaredNorm();
  }
  return std::sqrt(e / r);
}

inline double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// This process's CPU seconds (all threads): budgets and figures that a shared machine inflates least.
inline double processCpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace demnerf::bench
