#include "demnerf/mechanics/sharp_features.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace demnerf::mechanics {
namespace {

std::uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

/// The sharp edges as vertex pairs.
std::vector<std::pair<int, int>> sharpEdges(const core::TriangleMesh& surface, double angle_degrees) {
  std::unordered_map<std::uint64_t, std::vector<int>> faces_of;
  faces_of.reserve(3 * surface.faces.size());
  for (std::size_t f = 0; f < surface.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      faces_of[edgeKey(surface.faces[f][k], surface.faces[f][(k + 1) % 3])].push_back(static_cast<int>(f));
  std::vector<Eigen::Vector3d> normal(surface.faces.size());
  for (std::size_t f = 0; f < surface.faces.size(); ++f) {
    const auto& t = surface.faces[f];
    const Eigen::Vector3d& a = surface.vertices[t[0]];
    normal[f] = (surface.vertices[t[1]] - a).cross(surface.vertices[t[2]] - a).normalized();
  }
  const double cos_limit = std::cos(angle_degrees * M_PI / 180.0);
  std::vector<std::pair<int, int>> sharp;
  for (const auto& [key, faces] : faces_of) {
    if (faces.size() != 2) continue;
    // A degenerate triangle has no normal (NaN): its edges are not called sharp.
    const double c = normal[faces[0]].dot(normal[faces[1]]);
    if (std::isfinite(c) && c < cos_limit)
      sharp.emplace_back(static_cast<int>(key >> 32), static_cast<int>(key & 0xffffffffu));
  }
  // Hash order differs between standard libraries: sort for the same curves everywhere.
  std::sort(sharp.begin(), sharp.end());
  return sharp;
}

}  // namespace

std::vector<SharpCurve> sharpCurves(const core::TriangleMesh& surface, double angle_degrees) {
  const std::vector<std::pair<int, int>> edges = sharpEdges(surface, angle_degrees);
  std::vector<std::vector<int>> incident(surface.vertices.size());  // edge indices at each vertex
  for (std::size_t e = 0; e < edges.size(); ++e) {
    incident[edges[e].first].push_back(static_cast<int>(e));
    incident[edges[e].second].push_back(static_cast<int>(e));
  }
  std::vector<char> used(edges.size(), 0);
  std::vector<SharpCurve> curves;
  // Walks from `start` along edge `e` until a vertex that is not a plain continuation.
  const auto walk = [&](int start, int e) {
    SharpCurve curve;
    curve.points.push_back(surface.vertices[start]);
    int v = start;
    while (e >= 0 && !used[e]) {
      used[e] = 1;
      const int next = edges[e].first == v ? edges[e].second : edges[e].first;
      curve.length += (surface.vertices[next] - surface.vertices[v]).norm();
      curve.points.push_back(surface.vertices[next]);
      v = next;
      e = -1;
      if (incident[v].size() == 2)
        for (int candidate : incident[v])
          if (!used[candidate]) e = candidate;
    }
    curve.closed = v == start && curve.points.size() > 2;
    curve.dangling = !curve.closed && (incident[start].size() == 1 || incident[v].size() == 1);
    curves.push_back(std::move(curve));
  };
  // Open curves first, from their ends (corners and branches), then the closed loops left over.
  for (std::size_t v = 0; v < incident.size(); ++v)
    if (incident[v].size() != 2)
      for (int e : incident[v])
        if (!used[e]) walk(static_cast<int>(v), e);
  for (std::size_t e = 0; e < edges.size(); ++e)
    if (!used[e]) walk(edges[e].first, static_cast<int>(e));
  return curves;
}

}  // namespace demnerf::mechanics
