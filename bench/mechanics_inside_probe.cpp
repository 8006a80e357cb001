// How well a particle cloud describes its body to the default DEM (issue 13, the NeRF cuboid):
// the volume inside ParticleInsideTest (the region the cell quadrature integrates) against the
// surface's, and how far the surface particles' normals turn from a box's face normals.
// With mesh=SURFACE.ply smooth=R, each surface particle's normal is first replaced by the
// area-weighted normal of the surface's triangles within R of it (what a sampler that averaged the
// bumps over the particle's own patch would give).
//   mechanics_inside_probe cloud=P.ply surface_volume=V [box_lo=x,y,z box_hi=x,y,z] [step=0.0015]
//       [mesh=SURFACE.ply smooth=R]
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"

namespace core = demnerf::core;
using Eigen::Vector3d;

namespace {
Vector3d parse3(const std::string& s) {
  Vector3d v;
  std::sscanf(s.c_str(), "%lf,%lf,%lf", &v.x(), &v.y(), &v.z());
  return v;
}
}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto eq = s.find('=');
    if (eq != std::string::npos) a[s.substr(0, eq)] = s.substr(eq + 1);
  }
  core::ParticleCloud cloud = core::readParticles(a.at("cloud"));
  if (a.count("mesh") && a.count("smooth")) {
    const core::TriangleMesh mesh = core::readMesh(a["mesh"]);
    const double radius = std::stod(a["smooth"]);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!(cloud.areas[i] > 0)) continue;
      Vector3d sum = Vector3d::Zero();
      for (const auto& f : mesh.faces) {
        const Vector3d &p0 = mesh.vertices[f[0]], &p1 = mesh.vertices[f[1]], &p2 = mesh.vertices[f[2]];
        if (((p0 + p1 + p2) / 3.0 - cloud.positions[i]).norm() < radius) sum += 0.5 * (p1 - p0).cross(p2 - p0);
      }
      if (sum.norm() > 0) cloud.normals[i] = sum.normalized();
    }
  }
  const demnerf::mechanics::ParticleInsideTest test(cloud);
  Vector3d lo = cloud.positions[0], hi = lo;
  for (const Vector3d& x : cloud.positions) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  const double step = a.count("step") ? std::stod(a["step"]) : 0.0015, pad = 0.02;
  long inside = 0;
  for (double z = lo.z() - pad; z <= hi.z() + pad; z += step)
    for (double y = lo.y() - pad; y <= hi.y() + pad; y += step)
      for (double x = lo.x() - pad; x <= hi.x() + pad; x += step) inside += test.inside(Vector3d(x, y, z));
  const double volume = inside * step * step * step;
  const double reference = a.count("surface_volume") ? std::stod(a["surface_volume"]) : volume;
  std::printf("%zu particles: inside-test volume %.4g m^3 (%+.2f %% of the surface's)", cloud.size(), volume,
              100.0 * (volume / reference - 1.0));
  if (a.count("box_lo") && a.count("box_hi")) {
    // The exact box's face nearest each surface particle gives the normal it should have.
    const Vector3d blo = parse3(a["box_lo"]), bhi = parse3(a["box_hi"]);
    double sum = 0;
    int n = 0, over20 = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!(cloud.areas[i] > 0)) continue;
      const Vector3d& x = cloud.positions[i];
      double best = 1e9;
      Vector3d normal = Vector3d::Zero();
      for (int k = 0; k < 3; ++k) {
        if (std::abs(x(k) - blo(k)) < best) best = std::abs(x(k) - blo(k)), normal = -Vector3d::Unit(k);
        if (std::abs(x(k) - bhi(k)) < best) best = std::abs(x(k) - bhi(k)), normal = Vector3d::Unit(k);
      }
      const double angle = std::acos(std::clamp(cloud.normals[i].normalized().dot(normal), -1.0, 1.0)) * 180.0 / M_PI;
      sum += angle;
      over20 += angle > 20.0;
      ++n;
    }
    std::printf("; %d surface particles: normal off the box face by %.1f deg on average, %.0f %% by > 20 deg", n,
                sum / std::max(n, 1), 100.0 * over20 / std::max(n, 1));
  }
  std::printf("\n");
  return 0;
}
