#include "demnerf/mechanics/boundary_load_quadrature.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <utility>

#include "demnerf/mechanics/dirichlet_lift.hpp"

namespace demnerf::mechanics {
namespace {

// 6-point degree-4 triangle rule (Dunavant): exact for quadratic shape times linear traction.
std::vector<std::pair<Eigen::Vector3d, double>> faceRule() {
  std::vector<std::pair<Eigen::Vector3d, double>> rule;
  const double a1 = 0.108103018168070, b1 = 0.445948490915965, w1 = 0.223381589678011;
  const double a2 = 0.816847572980459, b2 = 0.091576213509771, w2 = 0.109951743655322;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d p1 = Eigen::Vector3d::Constant(b1), p2 = Eigen::Vector3d::Constant(b2);
    p1(i) = a1;
    p2(i) = a2;
    rule.emplace_back(p1, w1);
    rule.emplace_back(p2, w2);
  }
  return rule;
}

void addLoadedPart(const TetMesh& mesh, const BoundaryFace& face, const core::Region& region,
                   std::vector<BoundaryLoadPoint>& out) {
  static const auto rule = faceRule();
  const auto& el = mesh.elements[face.element];
  int local[3], k = 0;
  for (int v = 0; v < 4; ++v)
    if (v != face.opposite) local[k++] = v;
  const Eigen::Vector3d p0 = mesh.nodes[el[local[0]]], p1 = mesh.nodes[el[local[1]]], p2 = mesh.nodes[el[local[2]]];
  const double area = 0.5 * (p1 - p0).cross(p2 - p0).norm();
  // A face that ends the region (the T-bar's arm ends at x = 0.15) lies 6e-9 m outside it once the
  // mesh went through a float32 PLY: points within a rounding tolerance count as inside.
  const double tolerance =
      1e-6 * (p0.cwiseAbs().maxCoeff() + std::max({(p1 - p0).norm(), (p2 - p0).norm(), (p2 - p1).norm()}));
  const auto within = [&](const Eigen::Vector3d& q) {
    return region.contains(q) || regionDistance(region, q) <= tolerance;
  };
  const bool whole = within(p0) && within(p1) && within(p2);
  const int m = whole ? 1 : kLoadSubdivision;
  // Sub-triangle corners in the face's barycentric coordinates: the m x m split into "up" (i, j),
  // (i + 1, j), (i, j + 1) and "down" (i + 1, j), (i + 1, j + 1), (i, j + 1) triangles.
  const auto bary = [m](int i, int j) -> Eigen::Vector3d { return Eigen::Vector3d(m - i - j, i, j) / m; };
  const auto add = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    const Eigen::Vector3d centre = (a + b + c) / 3.0;
    if (!whole && !within(centre(0) * p0 + centre(1) * p1 + centre(2) * p2)) return;
    for (const auto& [r, w] : rule) {
      const Eigen::Vector3d beta = r(0) * a + r(1) * b + r(2) * c;
      Eigen::Vector4d L = Eigen::Vector4d::Zero();
      for (int v = 0; v < 3; ++v) L(local[v]) = beta(v);
      out.push_back({face.element, L, beta(0) * p0 + beta(1) * p1 + beta(2) * p2, w * area / (m * m)});
    }
  };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i + j < m; ++i) {
      add(bary(i, j), bary(i + 1, j), bary(i, j + 1));
      if (i + j + 1 < m) add(bary(i + 1, j), bary(i + 1, j + 1), bary(i, j + 1));
    }
}

}  // namespace

std::vector<BoundaryLoadPoint> boundaryLoadQuadrature(const TetMesh& mesh, const std::vector<BoundaryFace>& faces,
                                                      const core::Region& region) {
  std::vector<BoundaryLoadPoint> out;
  for (const BoundaryFace& face : faces) addLoadedPart(mesh, face, region, out);
  return out;
}

}  // namespace demnerf::mechanics
