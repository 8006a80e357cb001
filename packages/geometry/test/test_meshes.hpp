#pragma once
// Analytic meshes for the geometry tests: boxes and icospheres with known volume and area.

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry::testing {

/// Axis-aligned box, 12 outward triangles.
inline core::TriangleMesh makeBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  core::TriangleMesh mesh;
  for (int c = 0; c < 8; ++c) {
    mesh.vertices.emplace_back((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
  }
  // Quads (outward, counter-clockwise seen from outside), each split into two triangles.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.faces.push_back({q[0], q[1], q[2]});
    mesh.faces.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

/// Icosahedron subdivided `levels` times and projected onto the sphere.
inline core::TriangleMesh makeIcosphere(double radius, int levels, const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  core::TriangleMesh mesh;
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  const double raw[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                             {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (const auto& v : raw) mesh.vertices.push_back(Eigen::Vector3d(v[0], v[1], v[2]).normalized());
  mesh.faces = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      mesh.vertices.push_back((mesh.vertices[a] + mesh.vertices[b]).normalized());
      const int id = static_cast<int>(mesh.vertices.size()) - 1;
      midpoint[key] = id;
      return id;
    };
    std::vector<std::array<int, 3>> faces;
    for (const auto& f : mesh.faces) {
      const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
      faces.push_back({f[0], ab, ca});
      faces.push_back({f[1], bc, ab});
      faces.push_back({f[2], ca, bc});
      faces.push_back({ab, bc, ca});
    }
    mesh.faces = std::move(faces);
  }
  for (auto& v : mesh.vertices) v = centre + radius * v;
  return mesh;
}

/// Exact volume of the polyhedron, computed with a different formula from the library's
/// (tetrahedra from the first vertex instead of from the box centre).
inline double polyhedronVolume(const core::TriangleMesh& mesh) {
  const Eigen::Vector3d o = mesh.vertices[0];
  double v = 0;
  for (const auto& f : mesh.faces) {
    v += (mesh.vertices[f[0]] - o).dot((mesh.vertices[f[1]] - o).cross(mesh.vertices[f[2]] - o)) / 6.0;
  }
  return v;
}

}  // namespace demnerf::geometry::testing
