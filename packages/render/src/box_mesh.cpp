#include "demnerf/render/box_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::render {
namespace {

// The six face directions of a cell: axis and side (+1 / -1).
struct FaceDirection {
  int axis;
  int side;
};
constexpr FaceDirection kFaces[6] = {{0, +1}, {0, -1}, {1, +1}, {1, -1}, {2, +1}, {2, -1}};

// Grid coordinates along one axis: all box faces plus subdivisions so no step exceeds max_edge.
std::vector<double> axisBreakpoints(const std::vector<Eigen::AlignedBox3d>& boxes, int axis,
                                    double max_edge) {
  std::vector<double> planes;
  for (const auto& box : boxes) {
    planes.push_back(box.min()[axis]);
    planes.push_back(box.max()[axis]);
  }
  std::sort(planes.begin(), planes.end());
  // Merge planes closer than a tiny fraction of max_edge: they are the same plane written twice.
  std::vector<double> unique;
  for (double p : planes) {
    if (unique.empty() || p - unique.back() > 1e-9 * std::max(1.0, max_edge)) unique.push_back(p);
  }
  std::vector<double> result;
  for (std::size_t i = 0; i + 1 < unique.size(); ++i) {
    const double length = unique[i + 1] - unique[i];
    const int parts = std::max(1, static_cast<int>(std::ceil(length / max_edge - 1e-9)));
    for (int p = 0; p < parts; ++p) result.push_back(unique[i] + length * p / parts);
  }
  result.push_back(unique.back());
  return result;
}

}  // namespace

core::TriangleMesh meshStructuredSolid(const StructuredSolid& solid) {
  const auto& n = solid.cells;
  if (n[0] < 1 || n[1] < 1 || n[2] < 1) {
    throw core::Error("meshStructuredSolid: every axis needs at least one cell, got " +
                      std::to_string(n[0]) + " x " + std::to_string(n[1]) + " x " + std::to_string(n[2]));
  }
  if (!solid.occupied || !solid.node) {
    throw core::Error("meshStructuredSolid: the solid needs both an occupied() and a node() function");
  }
  const auto inside = [&](int i, int j, int k) {
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return false;
    return solid.occupied(i, j, k);
  };
  core::TriangleMesh mesh;
  // Node index -> vertex index, so neighbouring faces share their corners.
  std::map<long long, int> vertex_of_node;
  const auto vertex = [&](int i, int j, int k) {
    const long long key = (static_cast<long long>(i) * (n[1] + 1) + j) * (n[2] + 1) + k;
    const auto found = vertex_of_node.find(key);
    if (found != vertex_of_node.end()) return found->second;
    const int index = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(solid.node(i, j, k));
    vertex_of_node.emplace(key, index);
    return index;
  };
  for (int i = 0; i < n[0]; ++i) {
    for (int j = 0; j < n[1]; ++j) {
      for (int k = 0; k < n[2]; ++k) {
        if (!inside(i, j, k)) continue;
        for (const FaceDirection& face : kFaces) {
          std::array<int, 3> neighbour{i, j, k};
          neighbour[face.axis] += face.side;
          if (inside(neighbour[0], neighbour[1], neighbour[2])) continue;
          // The face's corners: fixed coordinate on the face's plane, the two other axes (a, b)
          // walked so that (b-axis direction) x ... gives the outward normal: for axis x the
          // cyclic order is (y, z), for y it is (z, x), for z it is (x, y).
          const int a = (face.axis + 1) % 3;
          const int b = (face.axis + 2) % 3;
          std::array<std::array<int, 3>, 4> corners;
          const int offsets[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
          for (int c = 0; c < 4; ++c) {
            std::array<int, 3> index{i, j, k};
            index[face.axis] += face.side > 0 ? 1 : 0;
            index[a] += offsets[c][0];
            index[b] += offsets[c][1];
            corners[c] = index;
          }
          std::array<int, 4> v;
          for (int c = 0; c < 4; ++c) v[c] = vertex(corners[c][0], corners[c][1], corners[c][2]);
          if (face.side > 0) {
            mesh.faces.push_back({v[0], v[1], v[2]});
            mesh.faces.push_back({v[0], v[2], v[3]});
          } else {
            mesh.faces.push_back({v[0], v[2], v[1]});
            mesh.faces.push_back({v[0], v[3], v[2]});
          }
        }
      }
    }
  }
  if (mesh.faces.empty()) throw core::Error("meshStructuredSolid: the solid has no occupied cell");
  return mesh;
}

core::TriangleMesh meshBoxUnion(const std::vector<Eigen::AlignedBox3d>& boxes, double max_edge) {
  if (boxes.empty()) throw core::Error("meshBoxUnion: no boxes given");
  if (!(max_edge > 0) || !std::isfinite(max_edge)) {
    throw core::Error("meshBoxUnion: max_edge must be a positive length in metres, got " +
                      std::to_string(max_edge));
  }
  for (const auto& box : boxes) {
    if (!(box.sizes().array() > 0).all() || !box.sizes().allFinite()) {
      throw core::Error("meshBoxUnion: every box needs positive, finite edge lengths");
    }
  }
  std::array<std::vector<double>, 3> coords;
  for (int axis = 0; axis < 3; ++axis) coords[axis] = axisBreakpoints(boxes, axis, max_edge);
  StructuredSolid solid;
  for (int axis = 0; axis < 3; ++axis) solid.cells[axis] = static_cast<int>(coords[axis].size()) - 1;
  solid.node = [&coords](int i, int j, int k) {
    return Eigen::Vector3d(coords[0][i], coords[1][j], coords[2][k]);
  };
  solid.occupied = [&coords, &boxes](int i, int j, int k) {
    const Eigen::Vector3d centre(0.5 * (coords[0][i] + coords[0][i + 1]),
                                 0.5 * (coords[1][j] + coords[1][j + 1]),
                                 0.5 * (coords[2][k] + coords[2][k + 1]));
    for (const auto& box : boxes) {
      if (box.contains(centre)) return true;
    }
    return false;
  };
  return meshStructuredSolid(solid);
}

double enclosedVolume(const core::TriangleMesh& mesh) {
  double six_volume = 0.0;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d& a = mesh.vertices[f[0]];
    const Eigen::Vector3d& b = mesh.vertices[f[1]];
    const Eigen::Vector3d& c = mesh.vertices[f[2]];
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

std::size_t countBoundaryOrInconsistentEdges(const core::TriangleMesh& mesh) {
  // A consistently oriented closed mesh uses each directed edge exactly once, and its reverse once.
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : mesh.faces) {
    for (int e = 0; e < 3; ++e) ++directed[{f[e], f[(e + 1) % 3]}];
  }
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (count != 1 || reverse == directed.end() || reverse->second != 1) ++bad;
  }
  return bad;
}

}  // namespace demnerf::render
