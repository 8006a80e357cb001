#include "demnerf/mechanics/held_volume_planes.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "demnerf/mechanics/held_face.hpp"

namespace demnerf::mechanics {

namespace {

/// Where the surface's edges cross the plane x[axis] = offset: the outline of the body's section.
std::vector<Eigen::Vector3d> sectionOutline(const core::TriangleMesh& surface, int axis, double offset) {
  std::vector<Eigen::Vector3d> outline;
  for (const auto& face : surface.faces)
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3d& a = surface.vertices[face[e]];
      const Eigen::Vector3d& b = surface.vertices[face[(e + 1) % 3]];
      const double da = a[axis] - offset, db = b[axis] - offset;
      if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) outline.push_back(a + (b - a) * (da / (da - db)));
    }
  return outline;
}

/// Points of the triangle (a, b, c) on its n x n subdivision, one per sub-triangle at its
/// centroid, each standing for area / n^2.
template <typename Visit>
void subdivisionCentroids(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, int n,
                          Visit&& visit) {
  const auto at = [&](double u, double v) { return a + (u / n) * (b - a) + (v / n) * (c - a); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; i + j < n; ++j) {
      visit(at(i + 1.0 / 3.0, j + 1.0 / 3.0));
      if (i + j < n - 1) visit(at(i + 2.0 / 3.0, j + 2.0 / 3.0));
    }
}

/// Whether the box grips a face of the surface, as the FEM decides it on its mesh's boundary
/// (heldMeshNodes): the surface inside the box has one dominant flat face. The triangles are
/// subdivided to a quarter of the box's thinnest side, so that an exact body's few large
/// triangles count by the part of them inside the box, not by whether their centroid is.
bool gripsAFace(const core::TriangleMesh& surface, const core::Region& box) {
  constexpr int kMaxSubdivision = 64;
  const double sample = 0.25 * box.size.minCoeff();
  std::vector<Eigen::Vector3d> points, normals;
  std::vector<double> areas;
  for (const auto& face : surface.faces) {
    const Eigen::Vector3d& a = surface.vertices[face[0]];
    const Eigen::Vector3d& b = surface.vertices[face[1]];
    const Eigen::Vector3d& c = surface.vertices[face[2]];
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c) - box.center, hi = a.cwiseMax(b).cwiseMax(c) - box.center;
    const bool apart = ((lo.array() > 0.5 * box.size.array()) || (hi.array() < -0.5 * box.size.array())).any();
    if (apart || !(cross.norm() > 0.0)) continue;
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const double pieces = sample > 0.0 ? std::ceil(longest / sample) : 1.0;
    const int n = static_cast<int>(std::clamp(pieces, 1.0, 1.0 * kMaxSubdivision));
    subdivisionCentroids(a, b, c, n, [&](const Eigen::Vector3d& x) {
      if (!box.contains(x)) return;
      points.push_back(x);
      normals.push_back(cross.normalized());
      areas.push_back(0.5 * cross.norm() / (n * n));
    });
  }
  return fitHeldFace(box, points, normals, areas).valid;
}

}  // namespace

std::vector<CgalMeshConfig::Plane> boxFacesAcrossBody(const core::TriangleMesh& surface, const core::Region& box,
                                                      double tolerance) {
  std::vector<CgalMeshConfig::Plane> planes;
  if (box.type != core::Region::Type::kBox) return planes;
  for (int axis = 0; axis < 3; ++axis)
    for (const double side : {-1.0, 1.0}) {
      const double offset = box.center[axis] + side * 0.5 * box.size[axis];
      const std::vector<Eigen::Vector3d> outline = sectionOutline(surface, axis, offset);
      bool within = !outline.empty();
      for (const Eigen::Vector3d& p : outline)
        for (int other = 0; other < 3 && within; ++other)
          within = other == axis || std::abs(p[other] - box.center[other]) <= 0.5 * box.size[other] + tolerance;
      if (!within) continue;
      Eigen::Vector3d point = box.center, normal = Eigen::Vector3d::Zero();
      point[axis] = offset;
      normal[axis] = side;
      planes.push_back({point, normal});
    }
  return planes;
}

std::vector<CgalMeshConfig::Plane> heldVolumePlanes(const core::Scenario& scenario,
                                                    const core::TriangleMesh& surface) {
  Eigen::AlignedBox3d bounds;
  for (const Eigen::Vector3d& v : surface.vertices) bounds.extend(v);
  const double tolerance = bounds.isEmpty() ? 0.0 : 1e-9 * bounds.diagonal().norm();
  std::vector<CgalMeshConfig::Plane> planes;
  for (const core::Fixture& fixture : scenario.fixtures) {
    const core::Region& region = fixture.region;
    if (region.type == core::Region::Type::kHalfspace) {
      planes.push_back({region.center, region.normal});
    } else if (region.type == core::Region::Type::kBox && !gripsAFace(surface, region)) {
      for (const CgalMeshConfig::Plane& plane : boxFacesAcrossBody(surface, region, tolerance)) planes.push_back(plane);
    }
  }
  return planes;
}

}  // namespace demnerf::mechanics
