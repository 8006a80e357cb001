#include "demnerf/mechanics/tet_mesh.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <functional>
#include <map>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

constexpr int kEdges[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};

std::array<Eigen::Vector3d, 4> corners(const TetMesh& mesh, const std::array<int, 10>& e) {
  return {mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]};
}

}  // namespace

TetMesh structuredMesh(const Eigen::Vector3i& cells, int order,
                       const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& map) {
  if ((cells.array() < 1).any()) throw core::Error("structuredMesh needs at least one cell per axis");
  if (order != 1 && order != 2) throw core::Error("tetrahedra of order " + std::to_string(order) + " are not supported: use 1 or 2");
  TetMesh mesh;
  const int nx = cells(0) + 1, ny = cells(1) + 1, nz = cells(2) + 1;
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const Eigen::Vector3d p(double(i) / cells(0), double(j) / cells(1), double(k) / cells(2));
        mesh.nodes.push_back(map ? map(p) : p);
      }
  // Kuhn split: all six tets share the hex diagonal (0,0,0)-(1,1,1), so neighbouring hexes
  // split their shared faces the same way and the mesh is conforming.
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < cells(2); ++k)
    for (int j = 0; j < cells(1); ++j)
      for (int i = 0; i < cells(0); ++i)
        for (const auto& p : perms) {
          Eigen::Vector3i v(i, j, k);
          std::array<int, 10> e;
          e.fill(-1);
          e[0] = id(v(0), v(1), v(2));
          for (int s = 0; s < 3; ++s) {
            v(p[s]) += 1;
            e[s + 1] = id(v(0), v(1), v(2));
          }
          double volume = 0;
          barycentricGradients(corners(mesh, e), &volume);
          if (volume < 0) std::swap(e[1], e[2]);
          mesh.elements.push_back(e);
        }
  return order == 2 ? elevateToQuadratic(mesh) : mesh;
}

TetMesh structuredBoxMesh(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper, const Eigen::Vector3i& cells,
                          int order) {
  return structuredMesh(cells, order, [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return lower + p.cwiseProduct(upper - lower);
  });
}

TetMesh elevateToQuadratic(const TetMesh& linear) {
  if (linear.order != 1) throw core::Error("elevateToQuadratic needs a linear mesh");
  TetMesh mesh = linear;
  mesh.order = 2;
  std::map<std::pair<int, int>, int> midpoint;
  for (auto& e : mesh.elements)
    for (int k = 0; k < 6; ++k) {
      const int a = e[kEdges[k][0]], b = e[kEdges[k][1]];
      const auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it == midpoint.end()) {
        it = midpoint.emplace(key, static_cast<int>(mesh.nodes.size())).first;
        mesh.nodes.push_back(0.5 * (mesh.nodes[a] + mesh.nodes[b]));
      }
      e[4 + k] = it->second;
    }
  return mesh;
}

std::vector<BoundaryFace> boundaryFaces(const TetMesh& mesh) {
  std::map<std::array<int, 3>, std::pair<int, BoundaryFace>> faces;
  for (int el = 0; el < static_cast<int>(mesh.elements.size()); ++el)
    for (int opposite = 0; opposite < 4; ++opposite) {
      std::array<int, 3> key;
      int n = 0;
      for (int c = 0; c < 4; ++c)
        if (c != opposite) key[n++] = mesh.elements[el][c];
      std::sort(key.begin(), key.end());
      auto& entry = faces[key];
      entry.first += 1;
      entry.second = BoundaryFace{el, opposite};
    }
  std::vector<BoundaryFace> out;
  for (const auto& [key, entry] : faces)
    if (entry.first == 1) out.push_back(entry.second);
  return out;
}

Eigen::VectorXd tetShape(int order, const Eigen::Vector4d& L) {
  if (order == 1) return L;
  Eigen::VectorXd N(10);
  for (int i = 0; i < 4; ++i) N(i) = L(i) * (2.0 * L(i) - 1.0);
  for (int k = 0; k < 6; ++k) N(4 + k) = 4.0 * L(kEdges[k][0]) * L(kEdges[k][1]);
  return N;
}

Eigen::MatrixXd tetShapeDerivatives(int order, const Eigen::Vector4d& L) {
  if (order == 1) return Eigen::MatrixXd::Identity(4, 4);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(10, 4);
  for (int i = 0; i < 4; ++i) D(i, i) = 4.0 * L(i) - 1.0;
  for (int k = 0; k < 6; ++k) {
    D(4 + k, kEdges[k][0]) = 4.0 * L(kEdges[k][1]);
    D(4 + k, kEdges[k][1]) = 4.0 * L(kEdges[k][0]);
  }
  return D;
}

Eigen::Matrix<double, 4, 3> barycentricGradients(const std::array<Eigen::Vector3d, 4>& c, double* volume) {
  Eigen::Matrix3d edges;
  edges << c[1] - c[0], c[2] - c[0], c[3] - c[0];
  const double det = edges.determinant();
  if (volume) *volume = det / 6.0;
  Eigen::Matrix<double, 4, 3> G;
  G.bottomRows<3>() = edges.inverse();  // rows: d L1/dX, d L2/dX, d L3/dX
  G.row(0) = -G.bottomRows<3>().colwise().sum();
  return G;
}

Eigen::Vector4d barycentric(const std::array<Eigen::Vector3d, 4>& c, const Eigen::Vector3d& x) {
  Eigen::Matrix3d edges;
  edges << c[1] - c[0], c[2] - c[0], c[3] - c[0];
  const Eigen::Vector3d l = edges.partialPivLu().solve(x - c[0]);
  return Eigen::Vector4d(1.0 - l.sum(), l(0), l(1), l(2));
}

namespace {

// Union-find over elements: two elements sharing a face (their three corner nodes) join one piece.
// Elements that meet only at an edge or a corner stay apart.
std::vector<int> faceConnectedPieces(const TetMesh& mesh) {
  const int count = static_cast<int>(mesh.elements.size());
  std::vector<std::pair<std::array<int, 3>, int>> faces;
  faces.reserve(4 * static_cast<std::size_t>(count));
  for (int e = 0; e < count; ++e)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> face{};
      for (int k = 0, f = 0; k < 4; ++k)
        if (k != skip) face[f++] = mesh.elements[e][k];
      std::sort(face.begin(), face.end());
      faces.emplace_back(face, e);
    }
  std::sort(faces.begin(), faces.end());
  std::vector<int> parent(count);
  for (int e = 0; e < count; ++e) parent[e] = e;
  const std::function<int(int)> root = [&](int e) { return parent[e] == e ? e : parent[e] = root(parent[e]); };
  for (std::size_t f = 1; f < faces.size(); ++f)
    if (faces[f].first == faces[f - 1].first) parent[root(faces[f].second)] = root(faces[f - 1].second);
  std::vector<int> piece(count);
  for (int e = 0; e < count; ++e) piece[e] = root(e);
  return piece;
}

}  // namespace

double tetMeshVolume(const TetMesh& mesh) {
  double volume = 0.0;
  for (const auto& e : mesh.elements) {
    Eigen::Matrix3d edges;
    edges << mesh.nodes[e[1]] - mesh.nodes[e[0]], mesh.nodes[e[2]] - mesh.nodes[e[0]], mesh.nodes[e[3]] - mesh.nodes[e[0]];
    volume += std::abs(edges.determinant()) / 6.0;
  }
  return volume;
}

TetMesh keepHeldPieces(const TetMesh& mesh, const std::function<bool(const Eigen::Vector3d&)>& held) {
  const std::vector<int> piece = faceConnectedPieces(mesh);
  const int per = mesh.nodesPerElement();
  std::vector<char> piece_held(mesh.elements.size(), 0);
  std::vector<char> node_held(mesh.nodes.size(), 0);
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i) node_held[i] = held(mesh.nodes[i]) ? 1 : 0;
  for (std::size_t e = 0; e < mesh.elements.size(); ++e)
    for (int k = 0; k < per; ++k)
      if (node_held[mesh.elements[e][k]]) piece_held[piece[e]] = 1;
  TetMesh kept;
  kept.order = mesh.order;
  std::vector<int> renumber(mesh.nodes.size(), -1);
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) {
    if (!piece_held[piece[e]]) continue;
    std::array<int, 10> element = mesh.elements[e];
    for (int k = 0; k < per; ++k) {
      int& n = renumber[mesh.elements[e][k]];
      if (n < 0) {
        n = static_cast<int>(kept.nodes.size());
        kept.nodes.push_back(mesh.nodes[mesh.elements[e][k]]);
      }
      element[k] = n;
    }
    kept.elements.push_back(element);
  }
  return kept.elements.empty() ? mesh : kept;
}

}  // namespace demnerf::mechanics
