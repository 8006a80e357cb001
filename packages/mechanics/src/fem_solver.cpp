#include "demnerf/mechanics/fem_solver.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>
#include <thread>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"

namespace demnerf::mechanics {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;

// Volume quadrature in barycentric coordinates (weights sum to 1): the centroid for linear
// elements, the 4-point degree-2 rule for quadratic ones (enough for their stiffness).
std::vector<std::pair<Eigen::Vector4d, double>> volumeRule(int order) {
  if (order == 1) return {{Eigen::Vector4d::Constant(0.25), 1.0}};
  const double a = 0.5854101966249685, b = 0.1381966011250105;
  std::vector<std::pair<Eigen::Vector4d, double>> rule;
  for (int i = 0; i < 4; ++i) {
    Eigen::Vector4d L = Eigen::Vector4d::Constant(b);
    L(i) = a;
    rule.emplace_back(L, 0.25);
  }
  return rule;
}

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

Eigen::Matrix3d deformationGradient(const Eigen::MatrixXd& dNdX, const Eigen::VectorXd& ue) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  for (int a = 0; a < dNdX.rows(); ++a) F += ue.segment<3>(3 * a) * dNdX.row(a);
  return F;
}

// Runs fn(begin, end) over [0, count) split into `threads` contiguous chunks.
template <typename Fn>
void parallelFor(int count, int threads, const Fn& fn) {
  if (threads <= 1 || count < 2 * threads) {
    fn(0, count);
    return;
  }
  std::vector<std::thread> pool;
  const int chunk = (count + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    const int begin = std::min(count, t * chunk), end = std::min(count, (t + 1) * chunk);
    if (begin < end) pool.emplace_back([&fn, begin, end] { fn(begin, end); });
  }
  fn(0, std::min(count, chunk));
  for (auto& t : pool) t.join();
}

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Nested dissection of the node graph by coordinate bisection: split the nodes at the median
// coordinate of their longest axis, take as separator the smaller of the two sets of nodes that
// touch the other side, order both halves recursively and the separator last. (On the T-bar
// meshes tried it gave more fill than AMD; see FemConfig::ordering.)
void dissect(std::vector<int>& nodes, int begin, int end, const std::vector<Eigen::Vector3d>& x,
             const std::vector<int>& adj_start, const std::vector<int>& adj, std::vector<int>& side,
             std::vector<int>& out) {
  const int count = end - begin;
  if (count <= 96) {
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  // Try the median split along each axis and keep the one with the smallest separator (bodies
  // like a T-bar are badly split along the longest axis of their bounding box).
  std::vector<int> best_sep;
  int best_axis = -1;
  double best_split = 0;
  std::vector<double> coord(count);
  for (int axis = 0; axis < 3; ++axis) {
    for (int i = 0; i < count; ++i) coord[i] = x[nodes[begin + i]](axis);
    std::nth_element(coord.begin(), coord.begin() + count / 2, coord.end());
    const double split = coord[count / 2];
    // Side 1: below the split, 2: at or above it; 0 marks nodes outside this subset.
    int below = 0;
    for (int i = begin; i < end; ++i) {
      side[nodes[i]] = x[nodes[i]](axis) < split ? 1 : 2;
      below += side[nodes[i]] == 1;
    }
    std::vector<int> touch[3];
    if (below > 0 && below < count)
      for (int i = begin; i < end; ++i) {
        const int v = nodes[i], s = side[v];
        for (int k = adj_start[v]; k < adj_start[v + 1]; ++k)
          if (side[adj[k]] != 0 && side[adj[k]] != s) {
            touch[s].push_back(v);
            break;
          }
      }
    for (int i = begin; i < end; ++i) side[nodes[i]] = 0;
    if (below == 0 || below == count) continue;
    const int sep_side = touch[1].size() <= touch[2].size() ? 1 : 2;
    if (best_axis < 0 || touch[sep_side].size() < best_sep.size()) {
      best_axis = axis;
      best_split = split;
      best_sep = touch[sep_side];
    }
  }
  if (best_axis < 0) {  // all nodes on one point: nothing to split
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  for (int i = begin; i < end; ++i) side[nodes[i]] = x[nodes[i]](best_axis) < best_split ? 1 : 2;
  for (int v : best_sep) side[v] = 3;
  std::vector<int> part[4];
  for (int i = begin; i < end; ++i) part[side[nodes[i]]].push_back(nodes[i]);
  for (int i = begin; i < end; ++i) side[nodes[i]] = 0;
  if (part[1].empty() || part[2].empty()) {  // no progress (all on one coordinate): stop here
    out.insert(out.end(), nodes.begin() + begin, nodes.begin() + end);
    return;
  }
  int pos = begin;
  const int b1 = pos;
  for (int v : part[1]) nodes[pos++] = v;
  const int b2 = pos;
  for (int v : part[2]) nodes[pos++] = v;
  const int b3 = pos;
  for (int v : part[3]) nodes[pos++] = v;
  dissect(nodes, b1, b2, x, adj_start, adj, side, out);
  dissect(nodes, b2, b3, x, adj_start, adj, side, out);
  out.insert(out.end(), part[3].begin(), part[3].end());
}

std::vector<int> nestedDissection(const std::vector<Eigen::Vector3d>& x, const std::vector<int>& adj_start,
                                  const std::vector<int>& adj) {
  const int n_nodes = static_cast<int>(x.size());
  std::vector<int> nodes(n_nodes), side(n_nodes, 0), out;
  for (int i = 0; i < n_nodes; ++i) nodes[i] = i;
  out.reserve(n_nodes);
  dissect(nodes, 0, n_nodes, x, adj_start, adj, side, out);
  return out;
}

}  // namespace

struct FemSolver::Impl {
  TetMesh mesh;
  core::Scenario scenario;
  FemConfig config;
  std::unique_ptr<HyperelasticMaterial> material;
  int n = 4;  // nodes per element
  int nq = 1;
  int threads = 1;
  std::vector<double> dNdX;    // per element and quadrature point, n x 3 row-major
  std::vector<double> weight;  // reference volume weight of each quadrature point
  std::vector<Eigen::Matrix<double, 4, 3>> grad_l;  // per element d L / d X
  Eigen::VectorXd f_ext;              // consistent nodal forces at full load
  Eigen::VectorXd prescribed;         // full-load values of constrained dofs
  std::vector<int> free_index;        // dof -> free dof number or -1
  int n_free = 0;
  Eigen::VectorXd u;
  FemResult result;
  // Free-free tangent, lower triangle, pattern fixed at setup; `scatter` holds for every element
  // and local dof pair (r >= c, packed) the position of its entry in K's values (-1: constrained).
  SparseMatrix K;
  std::vector<int> scatter;
  std::vector<std::vector<int>> colours;  // element ids; no two in a colour share a node
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt_nd;  // nodes pre-ordered
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_amd;
  bool analysed = false, factor_valid = false;
  // The running solve's clock (null: no budget, no reports) and the last converged load fraction.
  SolveClock* clock = nullptr;
  double done = 0.0;
  // Why the last Newton loop failed.
  enum class Failure { kNone, kInverted, kStalled };
  Failure failure = Failure::kNone;
  // Interpolation grid: element ids per cell.
  Eigen::Vector3d grid_lower, grid_cell;
  Eigen::Vector3i grid_dims;
  std::vector<std::vector<int>> grid;

  std::array<Eigen::Vector3d, 4> corners(int e) const {
    const auto& el = mesh.elements[e];
    return {mesh.nodes[el[0]], mesh.nodes[el[1]], mesh.nodes[el[2]], mesh.nodes[el[3]]};
  }
  Eigen::VectorXd elementDofs(const Eigen::VectorXd& x, int e) const {
    Eigen::VectorXd ue(3 * n);
    for (int a = 0; a < n; ++a) ue.segment<3>(3 * a) = x.segment<3>(3 * mesh.elements[e][a]);
    return ue;
  }

  void setup();
  void setupLoads();
  void setupPattern();
  void buildGrid();
  double energy(const Eigen::VectorXd& x, double scale) const;
  // Residual R = f_int - scale f_ext over all dofs, the free-free tangent into K, and K_fc du_c.
  double assemble(const Eigen::VectorXd& x, double scale, const Eigen::VectorXd& du, bool du_constrained,
                  Eigen::VectorXd& R, Eigen::VectorXd& Kdu_c, double& internal_norm);
  template <int N>
  double assembleT(const Eigen::VectorXd& x, const Eigen::VectorXd& du, bool du_constrained, Eigen::VectorXd& f_int,
                   Eigen::VectorXd& Kdu_c);
  template <int N>
  double elementEnergy(const Eigen::VectorXd& x, int e) const;
  bool newton(double scale);
  const FemResult& solveAll();
  void keepState();  // u -> result.displacement
  // eta: relative accuracy asked of an iterative solve (inexact Newton forcing term).
  Eigen::VectorXd solveLinear(const Eigen::VectorXd& rhs, double eta);
  int locate(const Eigen::Vector3d& x, Eigen::Vector4d& L) const;
  bool nd() const { return config.ordering == FemConfig::Ordering::kNestedDissection; }
  Eigen::VectorXd factorSolve(const Eigen::VectorXd& b) const {
    if (nd()) return ldlt_nd.solve(b);
    return ldlt_amd.solve(b);
  }
};

void FemSolver::Impl::setup() {
  scenario.validate("scenario '" + scenario.name + "'");
  material = makeMaterial(scenario.material);
  n = mesh.nodesPerElement();
  if (mesh.elements.empty()) throw core::Error("the FEM mesh has no elements");
  if (config.threads < 0) throw core::Error("FemConfig threads must be >= 0 (0: all cores), got " + std::to_string(config.threads));
  threads = config.threads > 0 ? config.threads : std::max(1u, std::thread::hardware_concurrency());
  const auto rule = volumeRule(mesh.order);
  nq = static_cast<int>(rule.size());
  const int ndof = 3 * static_cast<int>(mesh.nodes.size());
  f_ext = Eigen::VectorXd::Zero(ndof);
  dNdX.reserve(mesh.elements.size() * nq * n * 3);
  for (int e = 0; e < static_cast<int>(mesh.elements.size()); ++e) {
    for (int a = 0; a < n; ++a)
      if (mesh.elements[e][a] < 0 || mesh.elements[e][a] >= static_cast<int>(mesh.nodes.size()))
        throw core::Error("FEM element " + std::to_string(e) + " refers to a missing node");
    double volume = 0;
    const auto G = barycentricGradients(corners(e), &volume);
    if (!(volume > 0.0))
      throw core::Error("FEM element " + std::to_string(e) + " is inverted or degenerate (volume " + std::to_string(volume) + ")");
    grad_l.push_back(G);
    for (const auto& [L, w] : rule) {
      const Eigen::MatrixXd D = tetShapeDerivatives(mesh.order, L) * G;
      for (int a = 0; a < n; ++a)
        for (int J = 0; J < 3; ++J) dNdX.push_back(D(a, J));
      weight.push_back(w * volume);
      const Eigen::VectorXd N = tetShape(mesh.order, L);
      for (int a = 0; a < n; ++a) f_ext.segment<3>(3 * mesh.elements[e][a]) += N(a) * w * volume * scenario.body_force;
    }
  }
  const Dirichlet fixed = resolveFixtures(scenario, mesh.nodes);
  prescribed = Eigen::VectorXd::Zero(ndof);
  free_index.assign(ndof, 0);
  for (std::size_t k = 0; k < fixed.index.size(); ++k)
    for (int c = 0; c < 3; ++c)
      if (fixed.mask[k](c)) {
        free_index[3 * fixed.index[k] + c] = -1;
        prescribed(3 * fixed.index[k] + c) = fixed.value[k](c);
      }
  setupLoads();
  setupPattern();
  u = Eigen::VectorXd::Zero(ndof);
  buildGrid();
}

void FemSolver::Impl::setupPattern() {
  const int n_nodes = static_cast<int>(mesh.nodes.size());
  const int n_el = static_cast<int>(mesh.elements.size());
  // Node -> elements (CSR).
  std::vector<int> start(n_nodes + 1, 0), list(static_cast<std::size_t>(n_el) * n);
  for (const auto& el : mesh.elements)
    for (int a = 0; a < n; ++a) ++start[el[a] + 1];
  for (int i = 0; i < n_nodes; ++i) start[i + 1] += start[i];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int e = 0; e < n_el; ++e)
      for (int a = 0; a < n; ++a) list[fill[mesh.elements[e][a]]++] = e;
  }
  // Greedy colouring: an element takes the first colour none of its node neighbours has.
  std::vector<int> colour(n_el, -1), stamp;
  for (int e = 0; e < n_el; ++e) {
    for (int a = 0; a < n; ++a) {
      const int node = mesh.elements[e][a];
      for (int k = start[node]; k < start[node + 1]; ++k) {
        const int c = colour[list[k]];
        if (c < 0) continue;
        if (c >= static_cast<int>(stamp.size())) stamp.resize(c + 1, -1);
        stamp[c] = e;
      }
    }
    int c = 0;
    while (c < static_cast<int>(stamp.size()) && stamp[c] == e) ++c;
    colour[e] = c;
    if (c >= static_cast<int>(colours.size())) colours.resize(c + 1);
    colours[c].push_back(e);
  }
  // Node adjacency (CSR, sorted, self included).
  std::vector<int> adj_start(n_nodes + 1, 0), adj;
  {
    std::vector<int> mark(n_nodes, -1), neighbours;
    for (int node = 0; node < n_nodes; ++node) {
      neighbours.clear();
      for (int k = start[node]; k < start[node + 1]; ++k)
        for (int a = 0; a < n; ++a) {
          const int other = mesh.elements[list[k]][a];
          if (mark[other] != node) {
            mark[other] = node;
            neighbours.push_back(other);
          }
        }
      std::sort(neighbours.begin(), neighbours.end());
      adj.insert(adj.end(), neighbours.begin(), neighbours.end());
      adj_start[node + 1] = static_cast<int>(adj.size());
    }
  }
  // Node order for the factorisation, then free dofs numbered node by node in that order.
  std::vector<int> order;
  if (config.ordering == FemConfig::Ordering::kNestedDissection) {
    order = nestedDissection(mesh.nodes, adj_start, adj);
  } else {
    order.resize(n_nodes);
    for (int i = 0; i < n_nodes; ++i) order[i] = i;
  }
  std::vector<int> rank(n_nodes);
  for (int i = 0; i < n_nodes; ++i) rank[order[i]] = i;
  n_free = 0;
  for (int node : order)
    for (int c = 0; c < 3; ++c)
      if (free_index[3 * node + c] >= 0) free_index[3 * node + c] = n_free++;
  // Column pattern of the lower triangle: rows of a column come out sorted when the neighbour
  // nodes are visited in increasing rank.
  std::vector<int> outer(n_free + 1, 0), inner, neighbours;
  for (int node : order) {
    neighbours.clear();
    for (int k = adj_start[node]; k < adj_start[node + 1]; ++k)
      if (rank[adj[k]] >= rank[node]) neighbours.push_back(adj[k]);
    std::sort(neighbours.begin(), neighbours.end(), [&](int x, int y) { return rank[x] < rank[y]; });
    for (int c = 0; c < 3; ++c) {
      const int col = free_index[3 * node + c];
      if (col < 0) continue;
      for (int other : neighbours)
        for (int r = 0; r < 3; ++r) {
          const int row = free_index[3 * other + r];
          if (row >= col) inner.push_back(row);
        }
      outer[col + 1] = static_cast<int>(inner.size());
    }
  }
  K.resize(n_free, n_free);
  K.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
  std::copy(outer.begin(), outer.end(), K.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), K.innerIndexPtr());
  std::fill(K.valuePtr(), K.valuePtr() + inner.size(), 0.0);
  // Scatter positions.
  const int m = 3 * n, packed = m * (m + 1) / 2;
  scatter.assign(static_cast<std::size_t>(n_el) * packed, -1);
  parallelFor(n_el, threads, [&](int begin, int end) {
    for (int e = begin; e < end; ++e)
      for (int r = 0; r < m; ++r) {
        const int fr = free_index[3 * mesh.elements[e][r / 3] + r % 3];
        if (fr < 0) continue;
        for (int c = 0; c <= r; ++c) {
          const int fc = free_index[3 * mesh.elements[e][c / 3] + c % 3];
          if (fc < 0) continue;
          const int row = std::max(fr, fc), col = std::min(fr, fc);
          const int* first = K.innerIndexPtr() + K.outerIndexPtr()[col];
          const int* last = K.innerIndexPtr() + K.outerIndexPtr()[col + 1];
          scatter[static_cast<std::size_t>(e) * packed + r * (r + 1) / 2 + c] =
              static_cast<int>(std::lower_bound(first, last, row) - K.innerIndexPtr());
        }
      }
  });
}
void FemSolver::Impl::setupLoads() {
  const auto faces = boundaryFaces(mesh);
  const auto rule = faceRule();
  for (const core::Load& load : scenario.loads) {
    struct Point {
      int element;
      Eigen::Vector4d L;
    };
    std::vector<Point> where;
    std::vector<Eigen::Vector3d> points;
    std::vector<double> weights;
    for (const BoundaryFace& face : faces) {
      const auto c = corners(face.element);
      int local[3], k = 0;
      for (int v = 0; v < 4; ++v)
        if (v != face.opposite) local[k++] = v;
      const Eigen::Vector3d centroid = (c[local[0]] + c[local[1]] + c[local[2]]) / 3.0;
      if (!load.region.contains(centroid)) continue;
      const double area = 0.5 * (c[local[1]] - c[local[0]]).cross(c[local[2]] - c[local[0]]).norm();
      for (const auto& [b, w] : rule) {
        Eigen::Vector4d L = Eigen::Vector4d::Zero();
        Eigen::Vector3d x = Eigen::Vector3d::Zero();
        for (int v = 0; v < 3; ++v) {
          L(local[v]) = b(v);
          x += b(v) * c[local[v]];
        }
        where.push_back({face.element, L});
        points.push_back(x);
        weights.push_back(w * area);
      }
    }
    if (points.empty())
      throw core::Error("load '" + load.name + "' selects no boundary face of the FEM mesh (face centroids): region " +
                        load.region.describe());
    const WrenchTraction t = spreadWrench(points, weights, load.force, load.torque, "load '" + load.name + "'");
    for (std::size_t q = 0; q < points.size(); ++q) {
      const Eigen::VectorXd N = tetShape(mesh.order, where[q].L);
      const Eigen::Vector3d f = t.at(points[q]) * weights[q];
      for (int a = 0; a < n; ++a) f_ext.segment<3>(3 * mesh.elements[where[q].element][a]) += N(a) * f;
    }
  }
}


template <int N>
double FemSolver::Impl::elementEnergy(const Eigen::VectorXd& x, int e) const {
  const auto& el = mesh.elements[e];
  double psi = 0;
  for (int q = 0; q < nq; ++q) {
    const Eigen::Map<const Eigen::Matrix<double, N, 3, Eigen::RowMajor>> D(&dNdX[(static_cast<std::size_t>(e) * nq + q) * N * 3]);
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int a = 0; a < N; ++a) F.noalias() += x.segment<3>(3 * el[a]) * D.row(a);
    psi += material->energy(F) * weight[e * nq + q];
  }
  return psi;
}

double FemSolver::Impl::energy(const Eigen::VectorXd& x, double scale) const {
  const int n_el = static_cast<int>(mesh.elements.size());
  std::vector<double> psi(n_el);
  parallelFor(n_el, threads, [&](int begin, int end) {
    for (int e = begin; e < end; ++e) psi[e] = n == 4 ? elementEnergy<4>(x, e) : elementEnergy<10>(x, e);
  });
  // Summed in element order whatever the thread count.
  double total = -scale * f_ext.dot(x);
  for (double p : psi) total += p;
  return std::isfinite(total) ? total : std::numeric_limits<double>::infinity();
}

template <int N>
double FemSolver::Impl::assembleT(const Eigen::VectorXd& x, const Eigen::VectorXd& du, bool du_constrained,
                                  Eigen::VectorXd& f_int, Eigen::VectorXd& Kdu_c) {
  constexpr int M = 3 * N, packed = M * (M + 1) / 2;
  using ElementMatrix = Eigen::Matrix<double, M, M>;
  const int n_el = static_cast<int>(mesh.elements.size());
  std::vector<double> psi(n_el, 0.0);
  double* values = K.valuePtr();
  for (const std::vector<int>& colour : colours) {
    // No two elements of a colour share a node, so their scatters never touch the same entry and
    // every entry receives its contributions in colour order: deterministic for any thread count.
    parallelFor(static_cast<int>(colour.size()), threads, [&](int begin, int end) {
      Eigen::Matrix<double, M, 1> fe;
      ElementMatrix Ke;
      for (int k = begin; k < end; ++k) {
        const int e = colour[k];
        const auto& el = mesh.elements[e];
        fe.setZero();
        Ke.setZero();
        double psi_e = 0;
        for (int q = 0; q < nq; ++q) {
          const Eigen::Map<const Eigen::Matrix<double, N, 3, Eigen::RowMajor>> D(
              &dNdX[(static_cast<std::size_t>(e) * nq + q) * N * 3]);
          Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
          for (int a = 0; a < N; ++a) F.noalias() += x.segment<3>(3 * el[a]) * D.row(a);
          if (!(F.determinant() > 0.0)) {
            psi_e = std::numeric_limits<double>::infinity();
            break;
          }
          const double w = weight[e * nq + q];
          psi_e += material->energy(F) * w;
          const Eigen::Matrix3d P = w * material->stress(F);
          const Tangent A = w * material->tangent(F);
          // f_a = P dN_a/dX.
          const Eigen::Matrix<double, 3, N> PD = P * D.transpose();
          for (int a = 0; a < N; ++a) fe.template segment<3>(3 * a) += PD.col(a);
          // K(3a+i, 3b+k) = sum_JL D(a,J) A(3i+J, 3k+L) D(b,L): first contract L, then J.
          for (int kk = 0; kk < 3; ++kk) {
            const Eigen::Matrix<double, 9, N> AD = A.template block<9, 3>(0, 3 * kk) * D.transpose();
            for (int i = 0; i < 3; ++i) {
              const Eigen::Matrix<double, N, N> block = D * AD.template middleRows<3>(3 * i);
              for (int b = 0; b < N; ++b)
                for (int a = 0; a < N; ++a) Ke(3 * a + i, 3 * b + kk) += block(a, b);
            }
          }
        }
        psi[e] = psi_e;
        if (!std::isfinite(psi_e)) continue;
        const int* pos = &scatter[static_cast<std::size_t>(e) * packed];
        for (int r = 0; r < M; ++r) {
          const int gr = 3 * el[r / 3] + r % 3;
          f_int(gr) += fe(r);
          for (int c = 0; c <= r; ++c) {
            const int p = pos[r * (r + 1) / 2 + c];
            if (p >= 0) values[p] += Ke(r, c);
          }
        }
        if (du_constrained)
          for (int r = 0; r < M; ++r) {
            const int fr = free_index[3 * el[r / 3] + r % 3];
            if (fr < 0) continue;
            for (int c = 0; c < M; ++c) {
              const int gc = 3 * el[c / 3] + c % 3;
              if (free_index[gc] < 0) Kdu_c(fr) += Ke(r, c) * du(gc);
            }
          }
      }
    });
  }
  double total = 0;
  for (double p : psi) total += p;
  return total;
}

double FemSolver::Impl::assemble(const Eigen::VectorXd& x, double scale, const Eigen::VectorXd& du, bool du_constrained,
                                 Eigen::VectorXd& R, Eigen::VectorXd& Kdu_c, double& internal_norm) {
  Eigen::VectorXd f_int = Eigen::VectorXd::Zero(x.size());
  Kdu_c = Eigen::VectorXd::Zero(n_free);
  std::fill(K.valuePtr(), K.valuePtr() + K.nonZeros(), 0.0);
  const double psi = n == 4 ? assembleT<4>(x, du, du_constrained, f_int, Kdu_c) : assembleT<10>(x, du, du_constrained, f_int, Kdu_c);
  if (!std::isfinite(psi)) return std::numeric_limits<double>::infinity();
  R = f_int - scale * f_ext;
  internal_norm = f_int.norm();
  return psi - scale * f_ext.dot(x);
}

Eigen::VectorXd FemSolver::Impl::solveLinear(const Eigen::VectorXd& rhs, double eta) {
  if (config.linear_solver == FemConfig::LinearSolver::kConjugateGradient) {
    Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower, Eigen::IncompleteCholesky<double>> cg;
    cg.setTolerance(config.cg_tolerance);
    cg.setMaxIterations(10 * n_free);
    cg.compute(K);
    Eigen::VectorXd x = cg.solve(rhs);
    if (cg.info() != Eigen::Success) throw core::Error("FEM: conjugate gradients did not converge");
    result.cg_iterations += static_cast<int>(cg.iterations());
    return x;
  }
  auto t0 = std::chrono::steady_clock::now();
  if (factor_valid && config.reuse_factorisation_iterations > 0) {
    // Newton tangents change little between iterations and load steps: the last factorisation
    // is an excellent preconditioner, and a few triangular solves cost far less than a new one.
    const auto Ks = K.selfadjointView<Eigen::Lower>();
    const double target = eta * rhs.norm();
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n_free), r = rhs, z = factorSolve(r), p = z, Ap(n_free);
    double rz = r.dot(z);
    for (int it = 1; it <= config.reuse_factorisation_iterations; ++it) {
      Ap.noalias() = Ks * p;
      const double pAp = p.dot(Ap);
      if (!(pAp > 0.0)) break;  // not positive definite along p: refactorise
      const double alpha = rz / pAp;
      x += alpha * p;
      r -= alpha * Ap;
      ++result.cg_iterations;
      if (r.norm() <= target) {
        result.solve_seconds += secondsSince(t0);
        return x;
      }
      z = factorSolve(r);
      const double rz_new = r.dot(z);
      p = z + (rz_new / rz) * p;
      rz = rz_new;
    }
    result.solve_seconds += secondsSince(t0);
    t0 = std::chrono::steady_clock::now();
  }
  if (!analysed) {
    if (nd()) ldlt_nd.analyzePattern(K); else ldlt_amd.analyzePattern(K);
    analysed = true;
  }
  if (nd()) ldlt_nd.factorize(K); else ldlt_amd.factorize(K);
  ++result.factorisations;
  factor_valid = (nd() ? ldlt_nd.info() : ldlt_amd.info()) == Eigen::Success;
  if (!factor_valid) {
    if (result.factorisations == 1 && done == 0.0)
      throw SolveError(SolveFailure::kDegenerate,
                       "FEM: the stiffness at the rest state is singular: the fixtures do not hold the body against "
                       "rigid motion, or a piece of the mesh touches no fixture; widen the fixture regions");
    // A tangent at a far-off Newton iterate can be singular: the load step is retried smaller.
    return Eigen::VectorXd::Constant(n_free, std::numeric_limits<double>::quiet_NaN());
  }
  result.factorisation_seconds += secondsSince(t0);
  if (config.verbose && result.factorisations == 1)
    std::cerr << "fem: " << n_free << " free dofs, nnz(K lower) " << K.nonZeros() << ", nnz(L) "
              << (nd() ? ldlt_nd.matrixL().nestedExpression().nonZeros() : ldlt_amd.matrixL().nestedExpression().nonZeros())
              << ", first factorisation " << secondsSince(t0) << " s\n";
  t0 = std::chrono::steady_clock::now();
  Eigen::VectorXd x = factorSolve(rhs);
  result.solve_seconds += secondsSince(t0);
  return x;
}

bool FemSolver::Impl::newton(double scale) {
  const int ndof = static_cast<int>(u.size());
  Eigen::VectorXd R, Kdu_c, du(ndof);
  double internal_norm = 0, last_update = std::numeric_limits<double>::infinity();
  failure = Failure::kStalled;
  for (int it = 0; it <= config.max_newton_iterations; ++it) {
    if (clock) {
      std::ostringstream state;
      state << "the state at load fraction " << done;
      clock->check(state.str());
    }
    // The constrained dofs move towards their targets as part of the Newton step so that large
    // prescribed displacements do not invert the first layer of elements.
    bool at_target = true;
    for (int d = 0; d < ndof; ++d) {
      du(d) = free_index[d] < 0 ? scale * prescribed(d) - u(d) : 0.0;
      if (free_index[d] < 0 && std::abs(du(d)) > 0) at_target = false;
    }
    auto t0 = std::chrono::steady_clock::now();
    const double e0 = assemble(u, scale, du, !at_target, R, Kdu_c, internal_norm);
    result.assembly_seconds += secondsSince(t0);
    if (!std::isfinite(e0)) {
      failure = Failure::kInverted;
      return false;
    }
    Eigen::VectorXd R_free(n_free);
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) R_free(free_index[d]) = R(d);
    const double res = R_free.norm(), ref = internal_norm + scale * f_ext.norm();
    // Reported relative to the load (to the reactions when only displacements load the body).
    const double load = scale * f_ext.norm() > 0.0 ? scale * f_ext.norm() : internal_norm;
    result.residual = load > 0.0 ? res / load : res;
    if (config.verbose) std::cerr << "fem: scale " << scale << " it " << it << " |R| " << res << " ref " << ref << "\n";
    if (clock) {
      SolveProgress progress;
      progress.phase = "newton";
      progress.load_fraction = scale;
      progress.iteration = result.newton_iterations;
      progress.energy = e0;
      progress.residual = result.residual;
      clock->report(progress);
    }
    // Residuals of tiny loads drown in the round-off of P = mu (F - F^-T) + ..., so a vanishing
    // Newton update also counts as converged.
    if (at_target && (res <= config.tolerance * ref ||
                      (it > 0 && last_update <= config.displacement_tolerance * u.norm()))) return true;
    if (it == config.max_newton_iterations) break;
    // Far from the answer a rough direction is as good as an exact one; close to it the forcing
    // term shrinks with the residual so the quadratic convergence is kept.
    const double eta = std::clamp(res / std::max(ref, 1e-300), 1e-10, 1e-4);
    const Eigen::VectorXd du_free = solveLinear(-(R_free + Kdu_c), eta);
    if (!du_free.allFinite()) return false;  // a singular tangent: stalled
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) du(d) = du_free(free_index[d]);
    ++result.newton_iterations;
    // Backtracking on the potential energy; a step that inverts an element has infinite energy.
    t0 = std::chrono::steady_clock::now();
    const double slope = R.dot(du);
    double alpha = 1.0;
    bool accepted = false, any_finite = false;
    for (int k = 0; k < 12; ++k, alpha *= 0.5) {
      const Eigen::VectorXd trial = u + alpha * du;
      const double e = energy(trial, scale);
      if (!std::isfinite(e)) continue;
      any_finite = true;
      // Near convergence energy differences drown in round-off: allow a relative slack.
      if (!at_target || e <= e0 + 1e-4 * alpha * slope + 1e-12 * std::abs(e0)) {
        last_update = alpha * du.norm();
        u = trial;
        accepted = true;
        break;
      }
    }
    result.line_search_seconds += secondsSince(t0);
    if (!accepted) {
      if (!any_finite) failure = Failure::kInverted;
      return false;
    }
  }
  return false;
}

const FemResult& FemSolver::solve() {
  impl_->clock = nullptr;
  return impl_->solveAll();
}

const FemResult& FemSolver::solve(const SolveControl& control) {
  SolveClock clock(control, "fem");
  return solve(clock);
}

const FemResult& FemSolver::solve(SolveClock& clock) {
  impl_->clock = &clock;
  struct Detach {  // the clock lives only as long as this call
    Impl& m;
    ~Detach() { m.clock = nullptr; }
  } detach{*impl_};
  return impl_->solveAll();
}

void FemSolver::Impl::keepState() {
  result.displacement.resize(mesh.nodes.size());
  for (std::size_t i = 0; i < mesh.nodes.size(); ++i) result.displacement[i] = u.segment<3>(3 * i);
}

const FemResult& FemSolver::Impl::solveAll() {
  const auto start = std::chrono::steady_clock::now();
  const int steps = std::max(1, config.load_steps > 0 ? config.load_steps : scenario.load_steps);
  const double nominal = 1.0 / steps;
  double step = nominal, done_before = -1.0;
  done = 0.0;
  int halvings = 0;
  bool all_inverted = true;
  result = FemResult{};
  Eigen::VectorXd u_before;
  while (done < 1.0 - 1e-12) {
    const double target = std::min(1.0, done + step);
    const Eigen::VectorXd saved = u;
    // Secant predictor from the last two converged load levels: in a large rotation (the T-bar
    // twist) the first Newton steps from the last state overshoot badly, from the extrapolated
    // state they start near the answer.
    if (done_before >= 0.0 && done > done_before) {
      const Eigen::VectorXd predicted = u + (target - done) / (done - done_before) * (u - u_before);
      if (std::isfinite(energy(predicted, target))) u = predicted;
    }
    bool converged = false;
    try {
      converged = newton(target);
    } catch (const SolveError&) {  // out of time or cancelled: keep the last converged state
      u = saved;
      keepState();
      result.seconds = secondsSince(start);
      throw;
    }
    if (converged) {
      done_before = done;
      u_before = saved;
      done = target;
      ++result.load_steps;
      step = std::min(nominal, 2.0 * step);
      continue;
    }
    u = saved;
    step *= 0.5;
    all_inverted = all_inverted && failure == Failure::kInverted;
    if (++halvings > config.max_step_halvings) {
      keepState();
      result.seconds = secondsSince(start);
      std::ostringstream msg;
      msg << "FEM: Newton did not converge at load fraction " << target << " even after " << config.max_step_halvings
          << " load-step halvings; kept the state at load fraction " << done << ". ";
      if (all_inverted)
        msg << "Every try inverted elements (det F <= 0): the load is beyond what the body carries, or the mesh has "
               "slivers; try a smaller load, more load_steps, or a finer, better-shaped mesh";
      else
        msg << "Newton stalled (residual " << result.residual << " of the load): raise max_newton_iterations or "
               "load_steps, or check that the fixtures hold the body";
      throw SolveError(all_inverted ? SolveFailure::kInverted : SolveFailure::kNotConverged, msg.str());
    }
  }
  keepState();
  result.energy = energy(u, 1.0);
  result.seconds = secondsSince(start);
  if (config.verbose)
    std::cerr << "fem: " << result.seconds << " s: assembly " << result.assembly_seconds << ", factorisation "
              << result.factorisation_seconds << " (" << result.factorisations << "), solves " << result.solve_seconds
              << " (" << result.cg_iterations << " CG its), line search " << result.line_search_seconds << "; "
              << result.newton_iterations << " Newton its, " << colours.size() << " colours, " << threads
              << " threads\n";
  if (clock) {
    SolveProgress progress;
    progress.phase = "done";
    progress.load_fraction = 1.0;
    progress.iteration = result.newton_iterations;
    progress.energy = result.energy;
    progress.residual = result.residual;
    clock->report(progress, true);
  }
  return result;
}

void FemSolver::Impl::buildGrid() {
  Eigen::Vector3d lo = mesh.nodes[0], hi = mesh.nodes[0];
  for (const auto& p : mesh.nodes) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-12);
  // About two elements per cell on average.
  const double cells = std::max(1.0, mesh.elements.size() / 2.0);
  const double h = std::cbrt(extent.prod() / cells);
  grid_dims = (extent / h).array().ceil().cast<int>().cwiseMax(1).cwiseMin(256);
  grid_lower = lo;
  grid_cell = extent.cwiseQuotient(grid_dims.cast<double>());
  grid.assign(grid_dims.prod(), {});
  for (int e = 0; e < static_cast<int>(mesh.elements.size()); ++e) {
    const auto c = corners(e);
    Eigen::Vector3d a = c[0], b = c[0];
    for (const auto& p : c) {
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
    const Eigen::Vector3i i0 = ((a - lo).cwiseQuotient(grid_cell)).array().floor().cast<int>().max(0).min(grid_dims.array() - 1);
    const Eigen::Vector3i i1 = ((b - lo).cwiseQuotient(grid_cell)).array().floor().cast<int>().max(0).min(grid_dims.array() - 1);
    for (int z = i0(2); z <= i1(2); ++z)
      for (int y = i0(1); y <= i1(1); ++y)
        for (int x = i0(0); x <= i1(0); ++x) grid[x + grid_dims(0) * (y + grid_dims(1) * z)].push_back(e);
  }
}

int FemSolver::Impl::locate(const Eigen::Vector3d& x, Eigen::Vector4d& L) const {
  const Eigen::Vector3i c = ((x - grid_lower).cwiseQuotient(grid_cell)).array().floor().cast<int>();
  int best = -1;
  double best_score = -std::numeric_limits<double>::infinity();
  auto consider = [&](int e) {
    const Eigen::Vector4d l = barycentric(corners(e), x);
    if (l.minCoeff() > best_score) {
      best_score = l.minCoeff();
      best = e;
      L = l;
    }
  };
  for (int ring = 1; ring <= 2 && best_score < -1e-12; ++ring) {
    for (int z = c(2) - ring; z <= c(2) + ring; ++z)
      for (int y = c(1) - ring; y <= c(1) + ring; ++y)
        for (int xx = c(0) - ring; xx <= c(0) + ring; ++xx) {
          if (xx < 0 || y < 0 || z < 0 || xx >= grid_dims(0) || y >= grid_dims(1) || z >= grid_dims(2)) continue;
          for (int e : grid[xx + grid_dims(0) * (y + grid_dims(1) * z)]) consider(e);
        }
  }
  if (best < 0)  // far outside the mesh: take the best element anywhere
    for (int e = 0; e < static_cast<int>(mesh.elements.size()); ++e) consider(e);
  return best;
}

FemSolver::FemSolver(TetMesh mesh, const core::Scenario& scenario, FemConfig config) : impl_(std::make_unique<Impl>()) {
  impl_->mesh = std::move(mesh);
  impl_->scenario = scenario;
  impl_->config = config;
  impl_->setup();
}

FemSolver::~FemSolver() = default;
FemSolver::FemSolver(FemSolver&&) noexcept = default;

const FemResult& FemSolver::result() const { return impl_->result; }
const TetMesh& FemSolver::mesh() const { return impl_->mesh; }

PointField FemSolver::interpolate(const std::vector<Eigen::Vector3d>& points) const {
  const Impl& m = *impl_;
  PointField out;
  out.displacement.resize(points.size());
  out.von_mises.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector4d L;
    const int e = m.locate(points[i], L);
    // Slightly outside points extrapolate with the nearest element's own polynomial, which is
    // more accurate than clamping them onto its face.
    const Eigen::VectorXd ue = m.elementDofs(m.u, e);
    const Eigen::VectorXd N = tetShape(m.mesh.order, L);
    Eigen::Vector3d disp = Eigen::Vector3d::Zero();
    for (int a = 0; a < m.n; ++a) disp += N(a) * ue.segment<3>(3 * a);
    const Eigen::MatrixXd D = tetShapeDerivatives(m.mesh.order, L) * m.grad_l[e];
    const Eigen::Matrix3d F = deformationGradient(D, ue);
    out.displacement[i] = disp;
    out.von_mises[i] = F.determinant() > 0 ? vonMises(cauchyStress(F, m.material->stress(F)))
                                           : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

}  // namespace demnerf::mechanics
