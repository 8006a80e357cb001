#include "demnerf/geometry/mesh_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {
namespace {

struct EdgeUse {
  int forward = 0;   // traversals low -> high vertex index
  int backward = 0;  // traversals high -> low
};

std::uint64_t edgeKey(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b));
  const auto hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

}  // namespace

MeshSummary analyzeMesh(const core::TriangleMesh& mesh) {
  MeshSummary summary;
  summary.vertices = mesh.vertices.size();
  summary.faces = mesh.faces.size();
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (!mesh.vertices[v].allFinite()) {
      throw core::Error("mesh vertex " + std::to_string(v) + " is NaN or Inf");
    }
  }
  const int n = static_cast<int>(mesh.vertices.size());
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(mesh.faces.size() * 3);
  // Volume about the bounding-box centre rather than the origin: the same value, but less
  // cancellation for meshes far from the origin.
  for (const auto& face : mesh.faces) {
    for (int corner = 0; corner < 3; ++corner) {
      if (face[corner] < 0 || face[corner] >= n) {
        throw core::Error("mesh face uses vertex " + std::to_string(face[corner]) + " but the mesh has " +
                          std::to_string(n) + " vertices");
      }
      summary.bounds.extend(mesh.vertices[face[corner]]);
    }
  }
  const Eigen::Vector3d centre =
      summary.bounds.isEmpty() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : Eigen::Vector3d(summary.bounds.center());
  for (const auto& face : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[face[0]] - centre;
    const Eigen::Vector3d b = mesh.vertices[face[1]] - centre;
    const Eigen::Vector3d c = mesh.vertices[face[2]] - centre;
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    summary.area += area;
    summary.signed_volume += a.dot(b.cross(c)) / 6.0;
    if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2] || area == 0.0) {
      ++summary.degenerate_faces;
    }
    for (int corner = 0; corner < 3; ++corner) {
      const int from = face[corner];
      const int to = face[(corner + 1) % 3];
      if (from == to) continue;
      EdgeUse& use = edges[edgeKey(from, to)];
      (from < to ? use.forward : use.backward) += 1;
    }
  }
  for (const auto& entry : edges) {
    const int total = entry.second.forward + entry.second.backward;
    if (total == 1) ++summary.boundary_edges;
    else if (total > 2) ++summary.non_manifold_edges;
    else if (entry.second.forward != 1) ++summary.misoriented_edges;
  }
  return summary;
}

MeshSummary requireClosedMesh(const core::TriangleMesh& mesh, const std::string& what) {
  if (mesh.faces.empty() || mesh.vertices.empty()) {
    throw core::Error(what + " is empty (" + std::to_string(mesh.vertices.size()) + " vertices, " +
                      std::to_string(mesh.faces.size()) + " faces): a closed surface is needed");
  }
  const MeshSummary summary = analyzeMesh(mesh);
  for (std::size_t f = 0; f < mesh.faces.size() && summary.degenerate_faces > 0; ++f) {
    const auto& face = mesh.faces[f];
    const Eigen::Vector3d& a = mesh.vertices[face[0]];
    const double area = (mesh.vertices[face[1]] - a).cross(mesh.vertices[face[2]] - a).norm();
    if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2] || area == 0.0) {
      std::ostringstream message;
      message << what << " has " << summary.degenerate_faces << " degenerate face(s), e.g. face " << f
              << " (vertices " << face[0] << ", " << face[1] << ", " << face[2]
              << ") has zero area: repair the mesh (merge duplicate vertices, remove slivers)";
      throw core::Error(message.str());
    }
  }
  if (summary.boundary_edges > 0) {
    throw core::Error(what + " is open: " + std::to_string(summary.boundary_edges) +
                      " edge(s) belong to one face only; close its holes (geometry::repairMesh) first");
  }
  if (summary.non_manifold_edges > 0) {
    throw core::Error(what + " is not manifold: " + std::to_string(summary.non_manifold_edges) +
                      " edge(s) are shared by more than two faces");
  }
  if (summary.misoriented_edges > 0) {
    throw core::Error(what + " is not consistently oriented: " + std::to_string(summary.misoriented_edges) +
                      " edge(s) are traversed the same way by both of their faces");
  }
  const double scale = std::pow(summary.diagonal(), 3);
  if (!(summary.volume() > 1e-12 * scale)) {
    std::ostringstream message;
    message << what << " encloses no volume (" << summary.signed_volume
            << "): it is flat or degenerate, bounding box diagonal " << summary.diagonal();
    throw core::Error(message.str());
  }
  return summary;
}

core::TriangleMesh flippedFaces(const core::TriangleMesh& mesh) {
  core::TriangleMesh flipped = mesh;
  for (auto& face : flipped.faces) std::swap(face[1], face[2]);
  return flipped;
}

}  // namespace demnerf::geometry
