#include "demnerf/mechanics/surface_sharpening.hpp"

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace demnerf::mechanics {
namespace {

/// A surface particle's tangent plane, n . x = offset.
struct TangentPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double offset = 0.0;
  double distance(const Eigen::Vector3d& x) const { return normal.dot(x) - offset; }
};

/// The tangent plane that decides the signed distance at x (returned in `distance` when asked); a
/// zero normal beyond the surface particles' reach.
TangentPlane planeAt(const Eigen::Vector3d& x, const ParticleInsideTest& inside, double* distance = nullptr) {
  TangentPlane plane;
  const double d = inside.signedDistance(x, &plane.normal);
  plane.offset = plane.normal.dot(x - d * plane.normal);
  if (distance) *distance = d;
  return plane;
}

bool onDifferentFaces(const TangentPlane& a, const TangentPlane& b) {
  return a.normal.squaredNorm() > 0.0 && b.normal.squaredNorm() > 0.0 &&
         a.normal.dot(b.normal) < ParticleInsideTest::kEdgeCosine;
}

/// The planes that decide the signed distance at v and at six probes a step away along the axes,
/// which reach across any edge or corner beside v; those passing farther than a step from v are
/// dropped (a face beyond the feature, not one v lies between).
std::vector<TangentPlane> planesAround(const Eigen::Vector3d& v, const ParticleInsideTest& inside, double step) {
  std::vector<TangentPlane> planes;
  for (int probe = 0; probe < 7; ++probe) {
    Eigen::Vector3d x = v;
    if (probe > 0) x((probe - 1) / 2) += probe % 2 ? step : -step;
    const TangentPlane plane = planeAt(x, inside);
    if (plane.normal.squaredNorm() > 0.0 && std::abs(plane.distance(v)) <= step) planes.push_back(plane);
  }
  return planes;
}

bool spansAnEdge(const std::vector<TangentPlane>& planes) {
  for (std::size_t a = 0; a < planes.size(); ++a)
    for (std::size_t b = a + 1; b < planes.size(); ++b)
      if (onDifferentFaces(planes[a], planes[b])) return true;
  return false;
}

/// The smallest move of v that puts it on every plane (least squares; directions the planes do not
/// constrain are left alone): onto an edge's line, or a corner.
Eigen::Vector3d moveOntoPlanes(const Eigen::Vector3d& v, const std::vector<TangentPlane>& planes) {
  Eigen::Matrix3d normals = Eigen::Matrix3d::Zero();
  Eigen::Vector3d misfit = Eigen::Vector3d::Zero();
  for (const TangentPlane& p : planes) {
    normals += p.normal * p.normal.transpose();
    misfit -= p.normal * p.distance(v);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normals);
  const double largest = eigen.eigenvalues()(2);
  Eigen::Vector3d move = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    const double lambda = eigen.eigenvalues()(k);
    const Eigen::Vector3d axis = eigen.eigenvectors().col(k);
    if (lambda > 0.1 * largest) move += axis * (axis.dot(misfit) / lambda);
  }
  return move;
}

/// Moves v, whose signed distance is `distance`, onto the planes around it when it lies off the
/// surface between two faces; whether it moved.
bool snapOntoEdge(Eigen::Vector3d& v, double distance, const ParticleInsideTest& inside, double step) {
  // A crossing between samples that saw one plane lies on that face.
  if (std::abs(distance) <= 1e-3 * step) return false;
  const std::vector<TangentPlane> planes = planesAround(v, inside, step);
  if (!spansAnEdge(planes)) return false;
  const Eigen::Vector3d move = moveOntoPlanes(v, planes);
  if (!(move.norm() <= step)) return false;
  v += move;
  return true;
}

/// The point of the line where planes a and b meet nearest to x.
Eigen::Vector3d nearestOnBoth(const Eigen::Vector3d& x, const TangentPlane& a, const TangentPlane& b) {
  Eigen::Matrix2d gram;
  gram << 1.0, a.normal.dot(b.normal), a.normal.dot(b.normal), 1.0;
  const Eigen::Vector2d along = gram.inverse() * Eigen::Vector2d(-a.distance(x), -b.distance(x));
  return x + along(0) * a.normal + along(1) * b.normal;
}

/// A vertex on the body's edge for each triangle edge that cuts across it: keyed by the sorted
/// pair of its ends.
std::map<std::pair<int, int>, int> splitEdgesAcrossFaces(core::TriangleMesh& surface,
                                                         const std::vector<TangentPlane>& planes, double step) {
  const double on_plane = 1e-3 * step;
  std::map<std::pair<int, int>, int> split;
  for (const auto& face : surface.faces)
    for (int k = 0; k < 3; ++k) {
      const std::pair<int, int> key = std::minmax(face[k], face[(k + 1) % 3]);
      if (split.count(key)) continue;
      const TangentPlane &a = planes[key.first], &b = planes[key.second];
      const Eigen::Vector3d &xa = surface.vertices[key.first], &xb = surface.vertices[key.second];
      // Ends already on both planes (a corner, a snapped vertex) leave nothing to put back.
      if (!onDifferentFaces(a, b) || std::abs(b.distance(xa)) <= on_plane || std::abs(a.distance(xb)) <= on_plane)
        continue;
      const Eigen::Vector3d middle = 0.5 * (xa + xb);
      const Eigen::Vector3d edge_point = nearestOnBoth(middle, a, b);
      if ((edge_point - middle).norm() > step) continue;
      split[key] = static_cast<int>(surface.vertices.size());
      surface.vertices.push_back(edge_point);
    }
  return split;
}

/// Replaces each triangle by the ones its split edges make, in its orientation.
void retriangulate(core::TriangleMesh& surface, const std::map<std::pair<int, int>, int>& split) {
  std::vector<std::array<int, 3>> faces;
  faces.reserve(surface.faces.size() + 2 * split.size());
  const auto middleOf = [&](int a, int b) {
    const auto found = split.find(std::minmax(a, b));
    return found == split.end() ? -1 : found->second;
  };
  for (const auto& face : surface.faces) {
    std::array<int, 3> mid;
    int count = 0;
    for (int k = 0; k < 3; ++k) count += (mid[k] = middleOf(face[k], face[(k + 1) % 3])) >= 0;
    // Turn the triangle so the split edges come first: edge k runs from v[k] to v[k + 1].
    int turn = 0;
    while (count > 0 && count < 3 && !(mid[turn] >= 0 && (count == 1 || mid[(turn + 1) % 3] >= 0))) ++turn;
    const int v0 = face[turn], v1 = face[(turn + 1) % 3], v2 = face[(turn + 2) % 3];
    const int m01 = mid[turn], m12 = mid[(turn + 1) % 3], m20 = mid[(turn + 2) % 3];
    if (count == 0) {
      faces.push_back(face);
    } else if (count == 1) {
      faces.push_back({v0, m01, v2});
      faces.push_back({m01, v1, v2});
    } else if (count == 2) {
      faces.push_back({m01, v1, m12});
      // The quad v0, m01, m12, v2 by its shorter diagonal.
      const auto& x = surface.vertices;
      if ((x[v0] - x[m12]).squaredNorm() <= (x[m01] - x[v2]).squaredNorm()) {
        faces.push_back({v0, m01, m12});
        faces.push_back({v0, m12, v2});
      } else {
        faces.push_back({v0, m01, v2});
        faces.push_back({m01, m12, v2});
      }
    } else {
      faces.push_back({v0, m01, m20});
      faces.push_back({m01, v1, m12});
      faces.push_back({m20, m12, v2});
      faces.push_back({m01, m12, m20});
    }
  }
  surface.faces = std::move(faces);
}

}  // namespace

void sharpenEdges(core::TriangleMesh& surface, const ParticleInsideTest& inside, double step) {
  // Each vertex's plane, taken again only where the vertex moved.
  std::vector<TangentPlane> planes;
  planes.reserve(surface.vertices.size());
  for (Eigen::Vector3d& v : surface.vertices) {
    double distance = 0.0;
    const TangentPlane plane = planeAt(v, inside, &distance);
    planes.push_back(snapOntoEdge(v, distance, inside, step) ? planeAt(v, inside) : plane);
  }
  retriangulate(surface, splitEdgesAcrossFaces(surface, planes, step));
}

}  // namespace demnerf::mechanics
