#include "demnerf/geometry/iso_surface.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <unordered_map>

namespace demnerf::geometry {
namespace {

// The six tetrahedra of a cube around its diagonal from corner 0 to corner 7. Corner c is at
// offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). Each follows a monotone path 0 -> e_a ->
// e_a + e_b -> 7, so neighbouring cubes split their shared faces the same way.
constexpr int kTetrahedra[6][4] = {
    {0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

// Where the iso-surface cuts an edge, as a fraction from the inside end; kept off the ends so
// that faces from neighbouring edges never collapse to zero area.
constexpr double kMinFraction = 1e-3;

class Extractor {
 public:
  Extractor(const DensityGrid& grid, double threshold)
      : grid_(grid), threshold_(threshold), empty_value_(std::min(0.0, threshold - 1.0)) {}

  core::TriangleMesh run() {
    const Eigen::Vector3i& n = grid_.dims;
    // Cells span one padding layer on each side, whose nodes are empty space.
    for (int k = -1; k < n.z(); ++k) {
      for (int j = -1; j < n.y(); ++j) {
        for (int i = -1; i < n.x(); ++i) {
          polygoniseCell(i, j, k);
        }
      }
    }
    return std::move(mesh_);
  }

 private:
  double value(int i, int j, int k) const {
    const Eigen::Vector3i& n = grid_.dims;
    if (i < 0 || j < 0 || k < 0 || i >= n.x() || j >= n.y() || k >= n.z()) return empty_value_;
    return grid_.at(i, j, k);
  }
  std::uint64_t nodeId(int i, int j, int k) const {
    const Eigen::Vector3i n = grid_.dims + Eigen::Vector3i::Constant(2);
    return (static_cast<std::uint64_t>(k + 1) * n.y() + (j + 1)) * n.x() + (i + 1);
  }

  void polygoniseCell(int i, int j, int k) {
    std::array<double, 8> f;
    std::array<Eigen::Vector3i, 8> node;
    int above = 0;
    for (int c = 0; c < 8; ++c) {
      node[c] = Eigen::Vector3i(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
      f[c] = value(node[c].x(), node[c].y(), node[c].z());
      above += f[c] > threshold_;
    }
    if (above == 0 || above == 8) return;
    for (const auto& tet : kTetrahedra) {
      std::array<int, 4> in, out;
      int n_in = 0, n_out = 0;
      for (int c : tet) (f[c] > threshold_ ? in[n_in++] : out[n_out++]) = c;
      if (n_in == 0 || n_out == 0) continue;
      Eigen::Vector3d mean_in = Eigen::Vector3d::Zero(), mean_out = Eigen::Vector3d::Zero();
      for (int a = 0; a < n_in; ++a) mean_in += position(node[in[a]]) / n_in;
      for (int b = 0; b < n_out; ++b) mean_out += position(node[out[b]]) / n_out;
      const Eigen::Vector3d outward = mean_out - mean_in;
      auto cut = [&](int a, int b) { return edgeVertex(node[a], f[a], node[b], f[b]); };
      if (n_in == 1) {
        addTriangle(cut(in[0], out[0]), cut(in[0], out[1]), cut(in[0], out[2]), outward);
      } else if (n_in == 3) {
        addTriangle(cut(in[0], out[0]), cut(in[1], out[0]), cut(in[2], out[0]), outward);
      } else {
        // Two in (a, b), two out (c, d): the section is the quad ac, ad, bd, bc.
        const int ac = cut(in[0], out[0]), ad = cut(in[0], out[1]);
        const int bd = cut(in[1], out[1]), bc = cut(in[1], out[0]);
        addTriangle(ac, ad, bd, outward);
        addTriangle(ac, bd, bc, outward);
      }
    }
  }

  Eigen::Vector3d position(const Eigen::Vector3i& n) const { return grid_.node(n.x(), n.y(), n.z()); }

  int edgeVertex(const Eigen::Vector3i& inside, double f_in, const Eigen::Vector3i& outside, double f_out) {
    // Every tetrahedron edge joins a node to one whose offsets are all >= (a monotone path), so
    // (lower node, offset bits) names the edge uniquely.
    const Eigen::Vector3i lower = inside.cwiseMin(outside);
    const Eigen::Vector3i step = inside.cwiseMax(outside) - lower;
    const std::uint64_t key = nodeId(lower.x(), lower.y(), lower.z()) * 8 + (step.x() | (step.y() << 1) | (step.z() << 2));
    const auto found = vertex_of_edge_.find(key);
    if (found != vertex_of_edge_.end()) return found->second;
    double t = (f_in - threshold_) / (f_in - f_out);
    t = std::clamp(t, kMinFraction, 1.0 - kMinFraction);
    const Eigen::Vector3d p = position(inside) + t * (position(outside) - position(inside));
    const int id = static_cast<int>(mesh_.vertices.size());
    mesh_.vertices.push_back(p);
    vertex_of_edge_.emplace(key, id);
    return id;
  }

  void addTriangle(int a, int b, int c, const Eigen::Vector3d& outward) {
    const Eigen::Vector3d& pa = mesh_.vertices[a];
    const Eigen::Vector3d normal = (mesh_.vertices[b] - pa).cross(mesh_.vertices[c] - pa);
    if (normal.dot(outward) >= 0) mesh_.faces.push_back({a, b, c});
    else mesh_.faces.push_back({a, c, b});
  }

  const DensityGrid& grid_;
  double threshold_;
  double empty_value_;
  core::TriangleMesh mesh_;
  std::unordered_map<std::uint64_t, int> vertex_of_edge_;
};

}  // namespace

core::TriangleMesh extractIsoSurface(const DensityGrid& grid, double threshold) {
  grid.validate();
  return Extractor(grid, threshold).run();
}

}  // namespace demnerf::geometry
