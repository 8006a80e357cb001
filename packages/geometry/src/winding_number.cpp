#include "demnerf/geometry/winding_number.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace demnerf::geometry {

double windingNumber(const core::TriangleMesh& mesh, const Eigen::Vector3d& point) {
  double total = 0.0;
  for (const auto& face : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[face[0]] - point;
    const Eigen::Vector3d b = mesh.vertices[face[1]] - point;
    const Eigen::Vector3d c = mesh.vertices[face[2]] - point;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    // tan(omega / 2) = det[a b c] / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|)
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return total / (4.0 * M_PI);
}

}  // namespace demnerf::geometry
