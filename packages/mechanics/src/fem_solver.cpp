#include "demnerf/mechanics/fem_solver.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>

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

}  // namespace

struct FemSolver::Impl {
  TetMesh mesh;
  core::Scenario scenario;
  FemConfig config;
  std::unique_ptr<HyperelasticMaterial> material;
  int n = 4;  // nodes per element
  int nq = 1;
  std::vector<Eigen::MatrixXd> dNdX;  // per element and quadrature point (n x 3)
  std::vector<double> weight;         // reference volume weight of each quadrature point
  std::vector<Eigen::Matrix<double, 4, 3>> grad_l;  // per element d L / d X
  Eigen::VectorXd f_ext;              // consistent nodal forces at full load
  Eigen::VectorXd prescribed;         // full-load values of constrained dofs
  std::vector<int> free_index;        // dof -> free dof number or -1
  int n_free = 0;
  Eigen::VectorXd u;
  FemResult result;
  Eigen::SimplicialLDLT<SparseMatrix> ldlt;
  bool analysed = false;
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
  void buildGrid();
  double energy(const Eigen::VectorXd& x, double scale) const;
  // Residual R = f_int - scale f_ext over all dofs, the free-free tangent, and K_fc du_c.
  double assemble(const Eigen::VectorXd& x, double scale, const Eigen::VectorXd& du, Eigen::VectorXd& R,
                  SparseMatrix& K, Eigen::VectorXd& Kdu_c, double& internal_norm) const;
  bool newton(double scale);
  Eigen::VectorXd solveLinear(const SparseMatrix& K, const Eigen::VectorXd& rhs);
  int locate(const Eigen::Vector3d& x, Eigen::Vector4d& L) const;
};

void FemSolver::Impl::setup() {
  scenario.validate("scenario '" + scenario.name + "'");
  material = makeMaterial(scenario.material);
  n = mesh.nodesPerElement();
  if (mesh.elements.empty()) throw core::Error("the FEM mesh has no elements");
  const auto rule = volumeRule(mesh.order);
  nq = static_cast<int>(rule.size());
  const int ndof = 3 * static_cast<int>(mesh.nodes.size());
  f_ext = Eigen::VectorXd::Zero(ndof);
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
      dNdX.push_back(tetShapeDerivatives(mesh.order, L) * G);
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
  n_free = 0;
  for (int& f : free_index)
    if (f == 0) f = n_free++;
  setupLoads();
  u = Eigen::VectorXd::Zero(ndof);
  buildGrid();
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

double FemSolver::Impl::energy(const Eigen::VectorXd& x, double scale) const {
  double total = -scale * f_ext.dot(x);
  for (int e = 0; e < static_cast<int>(mesh.elements.size()); ++e) {
    const Eigen::VectorXd ue = elementDofs(x, e);
    for (int q = 0; q < nq; ++q) {
      const double psi = material->energy(deformationGradient(dNdX[e * nq + q], ue));
      if (!std::isfinite(psi)) return std::numeric_limits<double>::infinity();
      total += psi * weight[e * nq + q];
    }
  }
  return total;
}

double FemSolver::Impl::assemble(const Eigen::VectorXd& x, double scale, const Eigen::VectorXd& du,
                                 Eigen::VectorXd& R, SparseMatrix& K, Eigen::VectorXd& Kdu_c,
                                 double& internal_norm) const {
  const int ndof = static_cast<int>(x.size());
  Eigen::VectorXd f_int = Eigen::VectorXd::Zero(ndof);
  Kdu_c = Eigen::VectorXd::Zero(n_free);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(mesh.elements.size() * 9 * n * n);
  double psi_total = 0;
  Eigen::MatrixXd B(9, 3 * n);
  for (int e = 0; e < static_cast<int>(mesh.elements.size()); ++e) {
    const Eigen::VectorXd ue = elementDofs(x, e);
    Eigen::VectorXd fe = Eigen::VectorXd::Zero(3 * n);
    Eigen::MatrixXd Ke = Eigen::MatrixXd::Zero(3 * n, 3 * n);
    for (int q = 0; q < nq; ++q) {
      const Eigen::MatrixXd& D = dNdX[e * nq + q];
      const Eigen::Matrix3d F = deformationGradient(D, ue);
      if (!(F.determinant() > 0.0)) return std::numeric_limits<double>::infinity();
      psi_total += material->energy(F) * weight[e * nq + q];
      const Eigen::Matrix3d P = material->stress(F);
      const Tangent A = material->tangent(F);
      // B maps element dofs to F flattened row by row: dF_iJ = sum_a du_ai dN_a/dX_J.
      B.setZero();
      Eigen::Matrix<double, 9, 1> p;
      for (int i = 0; i < 3; ++i)
        for (int J = 0; J < 3; ++J) {
          p(3 * i + J) = P(i, J);
          for (int a = 0; a < n; ++a) B(3 * i + J, 3 * a + i) = D(a, J);
        }
      const double w = weight[e * nq + q];
      fe.noalias() += w * B.transpose() * p;
      Ke.noalias() += w * B.transpose() * A * B;
    }
    for (int r = 0; r < 3 * n; ++r) {
      const int gr = 3 * mesh.elements[e][r / 3] + r % 3;
      f_int(gr) += fe(r);
      const int fr = free_index[gr];
      if (fr < 0) continue;
      for (int c = 0; c < 3 * n; ++c) {
        const int gc = 3 * mesh.elements[e][c / 3] + c % 3;
        const int fc = free_index[gc];
        if (fc >= 0)
          triplets.emplace_back(fr, fc, Ke(r, c));
        else
          Kdu_c(fr) += Ke(r, c) * du(gc);
      }
    }
  }
  R = f_int - scale * f_ext;
  internal_norm = f_int.norm();
  K.resize(n_free, n_free);
  K.setFromTriplets(triplets.begin(), triplets.end());
  return psi_total - scale * f_ext.dot(x);
}

Eigen::VectorXd FemSolver::Impl::solveLinear(const SparseMatrix& K, const Eigen::VectorXd& rhs) {
  if (config.linear_solver == FemConfig::LinearSolver::kLDLT) {
    if (!analysed) {
      ldlt.analyzePattern(K);
      analysed = true;
    }
    ldlt.factorize(K);
    if (ldlt.info() != Eigen::Success) throw core::Error("FEM: the tangent stiffness could not be factorised");
    return ldlt.solve(rhs);
  }
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>> cg;
  cg.setTolerance(config.cg_tolerance);
  cg.setMaxIterations(10 * n_free);
  cg.compute(K);
  Eigen::VectorXd x = cg.solve(rhs);
  if (cg.info() != Eigen::Success) throw core::Error("FEM: conjugate gradients did not converge");
  return x;
}

bool FemSolver::Impl::newton(double scale) {
  const int ndof = static_cast<int>(u.size());
  Eigen::VectorXd R, Kdu_c, du(ndof);
  SparseMatrix K;
  double internal_norm = 0, last_update = std::numeric_limits<double>::infinity();
  for (int it = 0; it <= config.max_newton_iterations; ++it) {
    // The constrained dofs move towards their targets as part of the Newton step so that large
    // prescribed displacements do not invert the first layer of elements.
    bool at_target = true;
    for (int d = 0; d < ndof; ++d) {
      du(d) = free_index[d] < 0 ? scale * prescribed(d) - u(d) : 0.0;
      if (free_index[d] < 0 && std::abs(du(d)) > 0) at_target = false;
    }
    const double e0 = assemble(u, scale, du, R, K, Kdu_c, internal_norm);
    if (!std::isfinite(e0)) return false;
    Eigen::VectorXd R_free(n_free);
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) R_free(free_index[d]) = R(d);
    const double res = R_free.norm(), ref = internal_norm + scale * f_ext.norm();
    if (config.verbose) std::cerr << "fem: scale " << scale << " it " << it << " |R| " << res << " ref " << ref << "\n";
    // Residuals of tiny loads drown in the round-off of P = mu (F - F^-T) + ..., so a vanishing
    // Newton update also counts as converged.
    if (at_target && (res <= config.tolerance * ref ||
                      (it > 0 && last_update <= config.displacement_tolerance * u.norm()))) return true;
    if (it == config.max_newton_iterations) break;
    const Eigen::VectorXd du_free = solveLinear(K, -(R_free + Kdu_c));
    if (!du_free.allFinite()) return false;
    for (int d = 0; d < ndof; ++d)
      if (free_index[d] >= 0) du(d) = du_free(free_index[d]);
    ++result.newton_iterations;
    // Backtracking on the potential energy; a step that inverts an element has infinite energy.
    const double slope = R.dot(du);
    double alpha = 1.0;
    bool accepted = false;
    for (int k = 0; k < 12; ++k, alpha *= 0.5) {
      const Eigen::VectorXd trial = u + alpha * du;
      const double e = energy(trial, scale);
      if (!std::isfinite(e)) continue;
      // Near convergence energy differences drown in round-off: allow a relative slack.
      if (!at_target || e <= e0 + 1e-4 * alpha * slope + 1e-12 * std::abs(e0)) {
        last_update = alpha * du.norm();
        u = trial;
        accepted = true;
        break;
      }
    }
    if (!accepted) return false;
  }
  return false;
}

const FemResult& FemSolver::solve() {
  Impl& m = *impl_;
  const auto start = std::chrono::steady_clock::now();
  const int steps = std::max(1, m.scenario.load_steps);
  const double nominal = 1.0 / steps;
  double done = 0.0, step = nominal;
  int halvings = 0;
  m.result = FemResult{};
  while (done < 1.0 - 1e-12) {
    const double target = std::min(1.0, done + step);
    const Eigen::VectorXd saved = m.u;
    if (m.newton(target)) {
      done = target;
      ++m.result.load_steps;
      step = std::min(nominal, 2.0 * step);
    } else {
      m.u = saved;
      step *= 0.5;
      if (++halvings > m.config.max_step_halvings) {
        std::ostringstream msg;
        msg << "FEM: Newton did not converge at load fraction " << target << " even after " << m.config.max_step_halvings
            << " step halvings (elements invert or the load is beyond what the body carries); last good fraction "
            << done;
        throw core::Error(msg.str());
      }
    }
  }
  m.result.displacement.resize(m.mesh.nodes.size());
  for (std::size_t i = 0; i < m.mesh.nodes.size(); ++i) m.result.displacement[i] = m.u.segment<3>(3 * i);
  m.result.energy = m.energy(m.u, 1.0);
  m.result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return m.result;
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
