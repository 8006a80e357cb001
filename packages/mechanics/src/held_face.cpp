#include "demnerf/mechanics/held_face.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <set>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"

namespace demnerf::mechanics {
namespace {

// Members no thicker across their fitted plane than this share of their spread along it (variances:
// 0.1 is a thickness about a third of the extent) form a plane; a rough 60 mm base 4 mm deep gives
// about 0.01, a row of samples along one edge (no plane) far more.
constexpr double kFlatFaceSpread = 0.1;

// Members of the cluster around `direction` and their area.
double clusterArea(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& areas,
                   const Eigen::Vector3d& direction, std::vector<char>* member) {
  double area = 0.0;
  if (member) member->assign(normals.size(), 0);
  for (std::size_t i = 0; i < normals.size(); ++i) {
    if (normals[i].dot(direction) < kFaceNormalCosine) continue;
    area += areas[i];
    if (member) (*member)[i] = 1;
  }
  return area;
}

// The plane through `point` with unit normal `normal` cut by the axis-aligned box: the polygon's
// corners (where the plane crosses the box's 12 edges), ordered counterclockwise about `normal`.
std::vector<Eigen::Vector3d> clipPlaneToBox(const core::Region& box, const Eigen::Vector3d& point,
                                            const Eigen::Vector3d& normal) {
  const Eigen::Vector3d half = 0.5 * box.size;
  const auto corner = [&](int bits) {
    return Eigen::Vector3d(box.center + half.cwiseProduct(
                                            Eigen::Vector3d(bits & 1 ? 1 : -1, bits & 2 ? 1 : -1, bits & 4 ? 1 : -1)));
  };
  std::vector<Eigen::Vector3d> cut;
  for (int a = 0; a < 8; ++a)
    for (int axis = 0; axis < 3; ++axis) {
      if (a & (1 << axis)) continue;  // each edge once, from its lower corner
      const Eigen::Vector3d pa = corner(a), pb = corner(a | (1 << axis));
      const double sa = (pa - point).dot(normal), sb = (pb - point).dot(normal);
      if ((sa < 0) == (sb < 0) && sa != 0.0 && sb != 0.0) continue;
      if (sa == sb) continue;  // the edge lies in the plane: its corners come from other edges
      cut.push_back(pa + sa / (sa - sb) * (pb - pa));
    }
  if (cut.size() < 3) return {};
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : cut) centre += p;
  centre /= static_cast<double>(cut.size());
  const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
  std::sort(cut.begin(), cut.end(), [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
    return std::atan2((p - centre).dot(v), (p - centre).dot(u)) < std::atan2((q - centre).dot(v), (q - centre).dot(u));
  });
  // Corners hit by several edges appear more than once.
  const double tiny = 1e-12 * box.size.maxCoeff();
  std::vector<Eigen::Vector3d> polygon;
  for (const Eigen::Vector3d& p : cut)
    if (polygon.empty() || (p - polygon.back()).norm() > tiny) polygon.push_back(p);
  while (polygon.size() > 1 && (polygon.front() - polygon.back()).norm() <= tiny) polygon.pop_back();
  return polygon.size() >= 3 ? polygon : std::vector<Eigen::Vector3d>{};
}

// The normal of the plane through the members' positions (area-weighted least squares), where
// they span a plane; else, or where that plane leans out of the cluster, the members' mean normal.
// Why positions: on a rough face (a NeRF extraction's base, bumps of 3-4 mm) the mean of the
// sampled normals depends on which slopes the samples happen to sit on: the distortion-trained
// seed-2 T-bar's grid 1/10 cloud leaned its held base 7 degrees (normal y 0.12) while the bumps'
// plane leans under 1 degree, so one side of the base went unheld and the DEM twisted 1.4 % too
// far (docs/mechanics_matrix_nerf.md, "Two distortion-trained T-bars over 2 % at 1/10").
// On a flat face both agree.
Eigen::Vector3d facePlaneNormal(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& areas,
                                const FaceCluster& cluster, const Eigen::Vector3d& centroid, double area) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i)
    if (cluster.member[i]) scatter += areas[i] * (points[i] - centroid) * (points[i] - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter / area);
  const Eigen::Vector3d spread = eigen.eigenvalues();  // ascending
  // A plane: spread in two directions, the members' thickness across it well below their extent.
  if (!(spread(1) > 0.0) || !(spread(0) <= kFlatFaceSpread * spread(1))) return cluster.normal;
  Eigen::Vector3d normal = eigen.eigenvectors().col(0);
  if (normal.dot(cluster.normal) < 0.0) normal = -normal;
  return normal.dot(cluster.normal) >= kFaceNormalCosine ? normal : cluster.normal;
}

}  // namespace

FaceCluster dominantFace(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& areas) {
  FaceCluster out;
  double total = 0.0;
  for (double a : areas) total += a;
  if (normals.empty() || !(total > 0.0)) return out;
  // Candidate directions: the samples' own normals (at most 256 of them, evenly strided).
  const std::size_t stride = std::max<std::size_t>(1, normals.size() / 256);
  double best = -1.0;
  for (std::size_t i = 0; i < normals.size(); i += stride) {
    const double area = clusterArea(normals, areas, normals[i], nullptr);
    if (area > best) {
      best = area;
      out.normal = normals[i];
    }
  }
  // Twice: re-centre the direction on its members' mean normal, then re-select the members.
  for (int pass = 0; pass < 2; ++pass) {
    clusterArea(normals, areas, out.normal, &out.member);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < normals.size(); ++i)
      if (out.member[i]) mean += areas[i] * normals[i];
    if (mean.norm() > 0.0) out.normal = mean.normalized();
  }
  out.share = clusterArea(normals, areas, out.normal, &out.member) / total;
  return out;
}

HeldFace fitHeldFace(const core::Region& region, const std::vector<Eigen::Vector3d>& points,
                     const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& areas) {
  HeldFace face;
  if (region.type != core::Region::Type::kBox || points.empty()) return face;
  const FaceCluster cluster = dominantFace(normals, areas);
  if (!(cluster.share > kFaceAreaShare)) return face;  // two opposite sides of a plate never make a face
  double area = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i)
    if (cluster.member[i]) {
      area += areas[i];
      centroid += areas[i] * points[i];
    }
  if (!(area > 0.0)) return face;
  face.point = centroid / area;
  face.normal = facePlaneNormal(points, areas, cluster, face.point, area);
  face.polygon = clipPlaneToBox(region, face.point, face.normal);
  face.valid = !face.polygon.empty();
  return face;
}

std::vector<HeldFace> heldFaces(const core::Scenario& scenario, const core::ParticleCloud& cloud) {
  std::vector<HeldFace> faces;
  for (const core::Fixture& fixture : scenario.fixtures) {
    std::vector<Eigen::Vector3d> points, normals;
    std::vector<double> areas;
    if (fixture.region.type == core::Region::Type::kBox)
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        if (!cloud.isSurface(i) || !(cloud.areas[i] > 0.0) || !fixture.region.contains(cloud.positions[i])) continue;
        const double length = cloud.normals[i].norm();
        if (!(length > 0.0)) continue;
        points.push_back(cloud.positions[i]);
        normals.push_back(cloud.normals[i] / length);
        areas.push_back(cloud.areas[i]);
      }
    faces.push_back(fitHeldFace(fixture.region, points, normals, areas));
  }
  return faces;
}

double heldFaceDistance(const HeldFace& face, const Eigen::Vector3d& x, Eigen::Vector3d& grad, bool signed_across) {
  const Eigen::Vector3d& n = face.normal;
  const Eigen::Vector3d q = x - (x - face.point).dot(n) * n;  // x projected onto the plane
  const std::size_t m = face.polygon.size();
  bool inside = true;
  for (std::size_t k = 0; k < m && inside; ++k) {
    const Eigen::Vector3d& a = face.polygon[k];
    const Eigen::Vector3d& b = face.polygon[(k + 1) % m];
    inside = (b - a).cross(q - a).dot(n) >= 0.0;
  }
  if (inside && signed_across) {
    grad = -n;
    return (face.point - x).dot(n);  // the normal points out of the body: positive inside
  }
  Eigen::Vector3d nearest = q;
  if (!inside) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < m; ++k) {
      const Eigen::Vector3d& a = face.polygon[k];
      const Eigen::Vector3d ab = face.polygon[(k + 1) % m] - a;
      const double t = std::clamp((q - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      const Eigen::Vector3d p = a + t * ab;
      if ((q - p).squaredNorm() < best) {
        best = (q - p).squaredNorm();
        nearest = p;
      }
    }
  }
  const Eigen::Vector3d diff = x - nearest;
  const double d = diff.norm();
  grad = d > 0.0 ? Eigen::Vector3d(diff / d) : Eigen::Vector3d::Zero();
  return d;
}

std::vector<int> heldMeshNodes(const core::Region& region, const TetMesh& mesh, const std::vector<BoundaryFace>& faces) {
  // The boundary triangles inside the region (by centroid, with the loads' rounding tolerance).
  static const int kEdgeNode[4][4] = {{-1, 4, 6, 7}, {4, -1, 5, 8}, {6, 5, -1, 9}, {7, 8, 9, -1}};
  std::vector<Eigen::Vector3d> points, normals;
  std::vector<double> areas;
  std::vector<std::array<int, 6>> nodes;
  for (const BoundaryFace& f : faces) {
    const auto& el = mesh.elements[f.element];
    int local[3], k = 0;
    for (int v = 0; v < 4; ++v)
      if (v != f.opposite) local[k++] = v;
    const Eigen::Vector3d p0 = mesh.nodes[el[local[0]]], p1 = mesh.nodes[el[local[1]]], p2 = mesh.nodes[el[local[2]]];
    const Eigen::Vector3d centroid = (p0 + p1 + p2) / 3.0;
    const double tolerance = 1e-6 * (p0.cwiseAbs().maxCoeff() + (p1 - p0).norm() + (p2 - p0).norm());
    if (!region.contains(centroid) && regionDistance(region, centroid) > tolerance) continue;
    Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    if (n.dot(mesh.nodes[el[f.opposite]] - p0) > 0) n = -n;  // outward: away from the opposite corner
    if (!(n.norm() > 0.0)) continue;
    points.push_back(centroid);
    areas.push_back(0.5 * n.norm());
    normals.push_back(n.normalized());
    std::array<int, 6> ids{el[local[0]], el[local[1]], el[local[2]], -1, -1, -1};
    if (mesh.order == 2)
      for (int e = 0; e < 3; ++e) ids[3 + e] = el[kEdgeNode[local[e]][local[(e + 1) % 3]]];
    nodes.push_back(ids);
  }
  const HeldFace face = fitHeldFace(region, points, normals, areas);
  std::set<int> held;
  if (face.valid) {
    for (std::size_t t = 0; t < nodes.size(); ++t)
      if (normals[t].dot(face.normal) >= kFaceNormalCosine)
        for (int id : nodes[t])
          if (id >= 0) held.insert(id);
  } else {
    // Nodes the mesher put on the region's boundary (CgalMeshConfig::cut_planes) are held
    // whichever side of it their rounding left them.
    Eigen::Vector3d lo = mesh.nodes.empty() ? Eigen::Vector3d::Zero() : mesh.nodes.front(), hi = lo;
    for (const Eigen::Vector3d& x : mesh.nodes) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    const double on_boundary = 1e-9 * (hi - lo).norm();
    for (std::size_t i = 0; i < mesh.nodes.size(); ++i)
      if (region.contains(mesh.nodes[i]) || regionDistance(region, mesh.nodes[i]) <= on_boundary)
        held.insert(static_cast<int>(i));
  }
  return {held.begin(), held.end()};
}

Dirichlet resolveMeshFixtures(const core::Scenario& scenario, const TetMesh& mesh,
                              const std::vector<BoundaryFace>& faces) {
  return assembleFixtures(
      scenario, mesh.nodes.size(),
      [&](std::size_t f) { return heldMeshNodes(scenario.fixtures[f].region, mesh, faces); }, "FEM node");
}

Dirichlet resolveHeldParticles(const core::Scenario& scenario, const core::ParticleCloud& cloud,
                               const std::vector<HeldFace>& held) {
  return assembleFixtures(
      scenario, cloud.size(),
      [&](std::size_t f) {
        const core::Region& region = scenario.fixtures[f].region;
        const bool face = f < held.size() && held[f].valid;
        const double tiny = 1e-9 * region.size.maxCoeff();
        std::vector<int> out;
        for (std::size_t i = 0; i < cloud.size(); ++i) {
          if (!region.contains(cloud.positions[i])) continue;
          // A face holds its own surface particles: those whose normals join it, and those on its
          // plane (a lattice's corner particles, whose normals lean 55 degrees off it).
          Eigen::Vector3d unused;
          if (face && !(cloud.isSurface(i) && (cloud.normals[i].dot(held[f].normal) >=
                                                   kFaceNormalCosine * cloud.normals[i].norm() ||
                                               heldFaceDistance(held[f], cloud.positions[i], unused) <= tiny)))
            continue;
          out.push_back(static_cast<int>(i));
        }
        return out;
      },
      "particle");
}

}  // namespace demnerf::mechanics
