#include "demnerf/mechanics/mesh_size.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

double BodyMeasures::thickness() const {
  const double box = (upper - lower).minCoeff();
  if (!(area > 0.0) || !(volume > 0.0)) return box;
  return std::min(box, 4.0 * volume / area);
}

BodyMeasures measureSurface(const core::TriangleMesh& surface) {
  if (surface.vertices.empty() || surface.faces.empty())
    throw core::Error("mesh size: the surface mesh is empty; pass a closed triangle mesh");
  BodyMeasures body;
  body.lower = body.upper = surface.vertices[0];
  for (const auto& v : surface.vertices) {
    body.lower = body.lower.cwiseMin(v);
    body.upper = body.upper.cwiseMax(v);
  }
  // Signed volume relative to the box centre (less cancellation than relative to the origin).
  const Eigen::Vector3d c = 0.5 * (body.lower + body.upper);
  for (const auto& f : surface.faces) {
    const Eigen::Vector3d a = surface.vertices[f[0]] - c, b = surface.vertices[f[1]] - c, d = surface.vertices[f[2]] - c;
    body.volume += a.dot(b.cross(d)) / 6.0;
    body.area += 0.5 * (b - a).cross(d - a).norm();
  }
  // An inward-oriented surface still describes its body.
  body.volume = std::abs(body.volume);
  if (!(body.volume > 0.0))
    throw core::Error("mesh size: the surface encloses no volume; pass a closed triangle mesh");
  return body;
}

BodyMeasures measureParticles(const core::ParticleCloud& cloud) {
  BodyMeasures body;
  // Interior particles sit half a spacing inside the surface, surface particles on it: the box is
  // that of the interior ones widened by half a spacing, joined with that of the surface ones.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d surface_lo = lo, surface_hi = hi;
  std::size_t with_volume = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    body.volume += cloud.volumes[i];
    body.area += cloud.areas[i];
    if (cloud.volumes[i] > 0.0) {
      ++with_volume;
      lo = lo.cwiseMin(cloud.positions[i]);
      hi = hi.cwiseMax(cloud.positions[i]);
    } else if (cloud.areas[i] > 0.0) {
      surface_lo = surface_lo.cwiseMin(cloud.positions[i]);
      surface_hi = surface_hi.cwiseMax(cloud.positions[i]);
    }
  }
  if (!(body.volume > 0.0) || with_volume == 0)
    throw core::Error("mesh size: no particle has a volume; sample the body with `demnerf sample`");
  const double spacing = std::cbrt(body.volume / static_cast<double>(with_volume));
  body.lower = (lo.array() - 0.5 * spacing).matrix().cwiseMin(surface_lo);
  body.upper = (hi.array() + 0.5 * spacing).matrix().cwiseMax(surface_hi);
  return body;
}

namespace {
double dofsPerElement(int order) { return 3.0 * (order == 1 ? 0.2 : 1.5); }
}  // namespace

double expectedDofs(double volume, double cell, int order) {
  return 6.0 * volume / (cell * cell * cell) * dofsPerElement(order);
}

double automaticCell(const BodyMeasures& body, const MeshSizeRule& rule) {
  if (!(rule.elements_across > 0.0) || !std::isfinite(rule.elements_across))
    throw core::Error("mesh size: elements_across must be a number > 0, got " + std::to_string(rule.elements_across));
  if (!(rule.max_dofs >= 1.0) || !std::isfinite(rule.max_dofs))
    throw core::Error("mesh size: max_dofs must be a number >= 1, got " + std::to_string(rule.max_dofs));
  if (rule.order != 1 && rule.order != 2)
    throw core::Error("mesh size: order must be 1 (TET4) or 2 (TET10), got " + std::to_string(rule.order));
  const double thickness = body.thickness();
  if (!(thickness > 0.0) || !(body.volume > 0.0)) {
    std::ostringstream msg;
    msg << "mesh size: the body has no extent (thickness " << thickness << " m, volume " << body.volume << " m^3)";
    throw core::Error(msg.str());
  }
  const double accurate = thickness / rule.elements_across;
  const double affordable = std::cbrt(6.0 * body.volume * dofsPerElement(rule.order) / rule.max_dofs);
  return std::max(accurate, affordable);
}

}  // namespace demnerf::mechanics
