#include <algorithm>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {
namespace {

core::TriangleMesh outward(const core::TriangleMesh& mesh) {
  // Validate first so the messages name the real problem, then turn the faces outward: the
  // samplers' normals must point out of the body.
  const MeshSummary summary = requireClosedMesh(mesh);
  return summary.signed_volume < 0 ? flippedFaces(mesh) : mesh;
}

}  // namespace

PreparedMesh prepareMesh(const core::TriangleMesh& mesh) {
  core::TriangleMesh oriented = outward(mesh);
  InsideTest inside(oriented);
  PreparedMesh prepared{std::move(oriented), {}, {}, {}, {}, std::move(inside)};
  prepared.summary = analyzeMesh(prepared.mesh);
  const auto& faces = prepared.mesh.faces;
  prepared.normals.reserve(faces.size());
  prepared.face_areas.reserve(faces.size());
  prepared.cumulative_area.reserve(faces.size());
  double running = 0.0;
  for (const auto& f : faces) {
    const Eigen::Vector3d& a = prepared.mesh.vertices[f[0]];
    const Eigen::Vector3d cross = (prepared.mesh.vertices[f[1]] - a).cross(prepared.mesh.vertices[f[2]] - a);
    const double norm = cross.norm();
    prepared.normals.push_back(cross / norm);
    prepared.face_areas.push_back(0.5 * norm);
    running += 0.5 * norm;
    prepared.cumulative_area.push_back(running);
  }
  return prepared;
}

Eigen::Vector3d PreparedMesh::randomSurfacePoint(Rng& rng, int* face) const {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double target = uniform(rng) * cumulative_area.back();
  const auto it = std::upper_bound(cumulative_area.begin(), cumulative_area.end(), target);
  const int f = static_cast<int>(std::min<std::ptrdiff_t>(it - cumulative_area.begin(),
                                                          static_cast<std::ptrdiff_t>(cumulative_area.size()) - 1));
  double u = uniform(rng), v = uniform(rng);
  if (u + v > 1.0) {  // fold the far half of the parallelogram back onto the triangle
    u = 1.0 - u;
    v = 1.0 - v;
  }
  const auto& idx = mesh.faces[f];
  const Eigen::Vector3d& a = mesh.vertices[idx[0]];
  if (face) *face = f;
  return a + u * (mesh.vertices[idx[1]] - a) + v * (mesh.vertices[idx[2]] - a);
}

}  // namespace demnerf::geometry::detail
