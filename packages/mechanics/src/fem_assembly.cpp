// The FEM's discrete problem: per-element shape gradients and quadrature, consistent loads, and
// the energy, residual and tangent at a state (the tangent's sparsity pattern: fem_pattern.cpp).
#include <algorithm>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/boundary_load_quadrature.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "fem_solver_impl.hpp"
#include "parallel_for.hpp"

namespace demnerf::mechanics {
namespace {

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

}  // namespace

void FemSolver::Impl::setup() {
  scenario.validate("scenario '" + scenario.name + "'");
  material = makeMaterial(scenario.material);
  n = mesh.nodesPerElement();
  if (mesh.elements.empty()) throw core::Error("the FEM mesh has no elements");
  if (config.threads < 0) throw core::Error("FemConfig threads must be >= 0 (0: all cores), got " + std::to_string(config.threads));
  threads = assemblyThreads(config.threads);
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
  const std::vector<BoundaryFace> faces = boundaryFaces(mesh);  // the fixtures' and the loads'
  const Dirichlet fixed = resolveMeshFixtures(scenario, mesh, faces);
  prescribed = Eigen::VectorXd::Zero(ndof);
  free_index.assign(ndof, 0);
  for (std::size_t k = 0; k < fixed.index.size(); ++k)
    for (int c = 0; c < 3; ++c)
      if (fixed.mask[k](c)) {
        free_index[3 * fixed.index[k] + c] = -1;
        prescribed(3 * fixed.index[k] + c) = fixed.value[k](c);
      }
  setupLoads(faces);
  setupPattern();
  u = Eigen::VectorXd::Zero(ndof);
  buildGrid();
}

void FemSolver::Impl::setupLoads(const std::vector<BoundaryFace>& faces) {
  for (const core::Load& load : scenario.loads) {
    const std::vector<BoundaryLoadPoint> where = boundaryLoadQuadrature(mesh, faces, load.region);
    std::vector<Eigen::Vector3d> points;
    std::vector<double> weights;
    for (const BoundaryLoadPoint& q : where) {
      points.push_back(q.x);
      weights.push_back(q.weight);
    }
    if (points.empty())
      throw core::Error("load '" + load.name + "' selects no part of the FEM mesh's boundary: region " +
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
  parallelFor(n_el, threads, [&](long begin, long end) {
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
    parallelFor(static_cast<int>(colour.size()), threads, [&](long begin, long end) {
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

}  // namespace demnerf::mechanics
