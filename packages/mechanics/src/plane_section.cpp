#include "demnerf/mechanics/plane_section.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace demnerf::mechanics {

bool planeCutsBody(const core::TriangleMesh& surface, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                   double clearance) {
  const Eigen::Vector3d n = normal.normalized();
  double below = 0.0, above = 0.0;
  for (const Eigen::Vector3d& v : surface.vertices) {
    below = std::min(below, n.dot(v - point));
    above = std::max(above, n.dot(v - point));
  }
  return below < -clearance && above > clearance;
}

core::TriangleMesh planeSquare(const core::TriangleMesh& surface, const Eigen::Vector3d& point,
                               const Eigen::Vector3d& normal, double margin) {
  const Eigen::Vector3d n = normal.normalized(), t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : surface.vertices) centre += v;
  centre /= static_cast<double>(std::max<std::size_t>(surface.vertices.size(), 1));
  centre -= n.dot(centre - point) * n;  // onto the plane
  double half = 0.0;
  for (const Eigen::Vector3d& v : surface.vertices)
    half = std::max({half, std::abs(t1.dot(v - centre)), std::abs(t2.dot(v - centre))});
  half += margin;
  core::TriangleMesh square;
  for (const double a : {-half, half})
    for (const double b : {-half, half}) square.vertices.push_back(centre + a * t1 + b * t2);
  square.faces = {{0, 2, 3}, {0, 3, 1}};
  return square;
}

}  // namespace demnerf::mechanics
