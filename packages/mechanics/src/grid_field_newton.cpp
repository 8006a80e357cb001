#include "demnerf/mechanics/grid_field_newton.hpp"

#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "demnerf/core/error.hpp"
#include "extended_unknowns.hpp"
#include "shifted_cholesky.hpp"

namespace demnerf::mechanics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The problem in the grid's basis. Volume points are grouped by grid cell: the points of a cell
// share their supportSize() nodes, so a cell's stiffness is summed densely and scattered once.
class GridFieldEnergy {
 public:
  GridFieldEnergy(const GridFieldProblem& problem, const HyperelasticMaterial& material, const BsplineGrid& grid)
      : pb_(problem), material_(material), grid_(grid), S_(grid.supportSize()) {
    const long n = static_cast<long>(problem.points.size());
    if (problem.volume.size() != problem.points.size() || problem.offset.size() != problem.points.size() ||
        problem.grad_offset.size() != problem.points.size() || problem.D.size() != problem.points.size() ||
        problem.grad_D.size() != problem.points.size() || problem.body.size() != problem.points.size() ||
        problem.surface_offset.size() != problem.surface_points.size() ||
        problem.surface_D.size() != problem.surface_points.size() ||
        problem.surface_force.size() != problem.surface_points.size())
      throw core::Error("grid field problem: per-point arrays differ in length");
    // Points in cell order.
    order_.resize(n);
    std::iota(order_.begin(), order_.end(), 0L);
    std::vector<long> cell(n);
    for (long p = 0; p < n; ++p) cell[p] = grid.cellIndex(problem.points[p]);
    std::stable_sort(order_.begin(), order_.end(), [&](long a, long b) { return cell[a] < cell[b]; });
    for (long q = 0; q < n; ++q)
      if (q == 0 || cell[order_[q]] != cell[order_[q - 1]]) cell_start_.push_back(q);
    cell_start_.push_back(n);
    // Basis at the points (in cell order): phi_i = D_i N, Grad phi_i = N Grad D_i + D_i Grad N.
    nodes_.resize(n * S_);
    phi_.resize(n * S_);
    grad_phi_.resize(n * S_);
    std::vector<double> N(S_);
    std::vector<Eigen::Vector3d> dN(S_);
    std::vector<char> seen(grid.nodeCount(), 0);
    for (long q = 0; q < n; ++q) {
      const long p = order_[q];
      grid.evaluate(problem.points[p], &nodes_[q * S_], N.data(), dN.data());
      for (int s = 0; s < S_; ++s) {
        Eigen::Vector3d v;
        Eigen::Matrix3d g;
        for (int i = 0; i < 3; ++i) {
          v(i) = problem.D[p](i) * N[s];
          g.row(i) = N[s] * problem.grad_D[p].row(i) + problem.D[p](i) * dN[s].transpose();
        }
        phi_[q * S_ + s] = v;
        grad_phi_[q * S_ + s] = g;
        if (v.squaredNorm() > 0 || g.squaredNorm() > 0) seen[nodes_[q * S_ + s]] = 1;
      }
    }
    // Unknowns: 3 per node that some point sees.
    local_.assign(grid.nodeCount(), -1);
    for (long a = 0; a < grid.nodeCount(); ++a)
      if (seen[a]) {
        local_[a] = static_cast<long>(active_.size());
        active_.push_back(a);
      }
    surface_nodes_.resize(problem.surface_points.size() * S_);
    surface_phi_.resize(problem.surface_points.size() * S_);
    for (std::size_t q = 0; q < problem.surface_points.size(); ++q) {
      grid.evaluate(problem.surface_points[q], &surface_nodes_[q * S_], N.data(), dN.data());
      for (int s = 0; s < S_; ++s) surface_phi_[q * S_ + s] = problem.surface_D[q] * N[s];
    }
    buildPattern();
  }

  long unknowns() const { return 3 * static_cast<long>(active_.size()); }
  const std::vector<long>& activeNodes() const { return active_; }

  /// Potential energy at coefficients c (3 per active node); +inf when a point inverts.
  double energy(const Eigen::VectorXd& c, double* strain = nullptr, double* min_J = nullptr) const {
    double internal = 0.0, jmin = kInf;
    for (long q = 0; q < static_cast<long>(order_.size()); ++q) {
      const Eigen::Matrix3d F = deformationGradient(c, q);
      jmin = std::min(jmin, F.determinant());
      internal += pb_.volume[order_[q]] * material_.energy(F);
    }
    if (strain) *strain = internal;
    if (min_J) *min_J = jmin;
    return std::isfinite(internal) ? internal - work(c) : kInf;
  }

  /// Gradient and Hessian (the fixed sparsity pattern) at c.
  void derivatives(const Eigen::VectorXd& c, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>& hessian) const {
    gradient = -external_;
    hessian = pattern_;
    double* values = hessian.valuePtr();
    const int m = 3 * S_;
    Eigen::MatrixXd K(m, m), B(9, m), AB(9, m);
    for (std::size_t cell = 0; cell + 1 < cell_start_.size(); ++cell) {
      K.setZero();
      const long q0 = cell_start_[cell];
      for (long q = q0; q < cell_start_[cell + 1]; ++q) {
        const long p = order_[q];
        const Eigen::Matrix3d F = deformationGradient(c, q);
        const Eigen::Matrix3d P = material_.stress(F);
        const Tangent A = pb_.volume[p] * material_.tangent(F);
        // B maps the local unknowns (3 s + i) to Grad u flattened row by row (3 i + k).
        B.setZero();
        for (int s = 0; s < S_; ++s)
          for (int i = 0; i < 3; ++i) {
            const Eigen::Vector3d g = grad_phi_[q * S_ + s].row(i).transpose();
            B.block<3, 1>(3 * i, 3 * s + i) = g;
            const long l = local_[nodes_[q * S_ + s]];
            if (l >= 0) gradient(3 * l + i) += pb_.volume[p] * P.row(i).dot(g);
          }
        AB.noalias() = A * B;
        K.noalias() += B.transpose() * AB;
      }
      scatter(K, q0, values);
    }
    // A component a fixture prescribes everywhere on a node's support (a plane-strain u_z = 0)
    // has an empty row and column: give it a unit pivot so the factorisation needs no shift. Its
    // gradient is zero, so it never moves.
    double mean = 0.0;
    for (Eigen::Index k = 0; k < hessian.rows(); ++k) mean += std::abs(hessian.coeff(k, k));
    mean = std::max(mean / std::max<Eigen::Index>(1, hessian.rows()), std::numeric_limits<double>::min());
    for (Eigen::Index k = 0; k < hessian.rows(); ++k)
      if (hessian.coeff(k, k) == 0.0) hessian.coeffRef(k, k) = mean;
  }

  double work(const Eigen::VectorXd& c) const { return external_.dot(c) + external_offset_; }
  double externalNorm() const { return external_.norm(); }

 private:
  Eigen::Matrix3d deformationGradient(const Eigen::VectorXd& c, long q) const {
    const long p = order_[q];
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + pb_.grad_offset[p];
    for (int s = 0; s < S_; ++s) {
      const long l = local_[nodes_[q * S_ + s]];
      if (l < 0) continue;
      const Eigen::Matrix3d& g = grad_phi_[q * S_ + s];
      for (int i = 0; i < 3; ++i) F.row(i) += c(3 * l + i) * g.row(i);
    }
    return F;
  }

  // The Hessian's pattern: node b's column block holds the active nodes whose supports overlap
  // b's (index distance <= degree on every axis), rows in ascending order; and the work vector.
  void buildPattern() {
    const int d = grid_.degree();
    const Eigen::Vector3i nn = grid_.cells() + Eigen::Vector3i::Constant(d);
    auto ijk = [&](long a) { return Eigen::Vector3i(a % nn(0), (a / nn(0)) % nn(1), a / (nn(0) * nn(1))); };
    const long na = static_cast<long>(active_.size());
    neighbours_.assign(na, {});
    for (long lb = 0; lb < na; ++lb) {
      const Eigen::Vector3i b = ijk(active_[lb]);
      for (int k = std::max(0, b(2) - d); k <= std::min(nn(2) - 1, b(2) + d); ++k)
        for (int j = std::max(0, b(1) - d); j <= std::min(nn(1) - 1, b(1) + d); ++j)
          for (int i = std::max(0, b(0) - d); i <= std::min(nn(0) - 1, b(0) + d); ++i) {
            const long la = local_[(static_cast<long>(k) * nn(1) + j) * nn(0) + i];
            if (la >= 0) neighbours_[lb].push_back(la);
          }
      std::sort(neighbours_[lb].begin(), neighbours_[lb].end());
    }
    pattern_.resize(3 * na, 3 * na);
    Eigen::VectorXi per_column(3 * na);
    for (long lb = 0; lb < na; ++lb)
      for (int j = 0; j < 3; ++j) per_column(3 * lb + j) = 3 * static_cast<int>(neighbours_[lb].size());
    pattern_.reserve(per_column);
    for (long lb = 0; lb < na; ++lb)
      for (int j = 0; j < 3; ++j)
        for (long la : neighbours_[lb])
          for (int i = 0; i < 3; ++i) pattern_.insert(3 * la + i, 3 * lb + j) = 0.0;
    pattern_.makeCompressed();
    // External work per unknown and the offset's share.
    external_ = Eigen::VectorXd::Zero(3 * na);
    external_offset_ = 0.0;
    for (long q = 0; q < static_cast<long>(order_.size()); ++q) {
      const long p = order_[q];
      external_offset_ += pb_.body[p].dot(pb_.offset[p]);
      for (int s = 0; s < S_; ++s) {
        const long l = local_[nodes_[q * S_ + s]];
        if (l >= 0) external_.segment<3>(3 * l) += pb_.body[p].cwiseProduct(phi_[q * S_ + s]);
      }
    }
    for (std::size_t q = 0; q < pb_.surface_points.size(); ++q) {
      external_offset_ += pb_.surface_force[q].dot(pb_.surface_offset[q]);
      for (int s = 0; s < S_; ++s) {
        const long l = local_[surface_nodes_[q * S_ + s]];
        if (l >= 0) external_.segment<3>(3 * l) += pb_.surface_force[q].cwiseProduct(surface_phi_[q * S_ + s]);
      }
    }
  }

  // Adds a cell's dense stiffness (local unknowns 3 s + i) into the pattern's values.
  void scatter(const Eigen::MatrixXd& K, long q0, double* values) const {
    const int* outer = pattern_.outerIndexPtr();
    for (int sb = 0; sb < S_; ++sb) {
      const long lb = local_[nodes_[q0 * S_ + sb]];
      if (lb < 0) continue;
      const auto& nb = neighbours_[lb];
      for (int sa = 0; sa < S_; ++sa) {
        const long la = local_[nodes_[q0 * S_ + sa]];
        if (la < 0) continue;
        const long rank = std::lower_bound(nb.begin(), nb.end(), la) - nb.begin();
        for (int j = 0; j < 3; ++j) {
          double* column = values + outer[3 * lb + j] + 3 * rank;
          for (int i = 0; i < 3; ++i) column[i] += K(3 * sa + i, 3 * sb + j);
        }
      }
    }
  }

  const GridFieldProblem& pb_;
  const HyperelasticMaterial& material_;
  const BsplineGrid& grid_;
  const int S_;
  std::vector<long> order_, cell_start_;
  std::vector<long> nodes_;
  std::vector<Eigen::Vector3d> phi_;
  std::vector<Eigen::Matrix3d> grad_phi_;  // row i: Grad phi_i
  std::vector<long> surface_nodes_;
  std::vector<Eigen::Vector3d> surface_phi_;
  std::vector<long> local_, active_;
  std::vector<std::vector<long>> neighbours_;
  Eigen::SparseMatrix<double> pattern_;
  Eigen::VectorXd external_;
  double external_offset_ = 0.0;
};

}  // namespace

GridNewtonOutcome minimiseGridField(const GridFieldProblem& problem, const HyperelasticMaterial& material,
                                    const BsplineGrid& grid, Eigen::MatrixXd& C, const GridNewtonConfig& config) {
  if (C.rows() != grid.nodeCount() || C.cols() != 3)
    throw core::Error("grid field coefficients must be nodeCount x 3");
  const GridFieldEnergy energy(problem, material, grid);
  const auto& active = energy.activeNodes();
  const Unknowns unknowns(problem, grid, active, config.extension_fill);
  Eigen::VectorXd c(energy.unknowns());
  for (std::size_t l = 0; l < active.size(); ++l) c.segment<3>(3 * l) = C.row(active[l]).transpose();
  // With the extension the start is projected onto the extended basis (outer nodes extrapolated).
  Eigen::VectorXd r = unknowns.reduce(c);
  c = unknowns.full(r);
  GridNewtonOutcome out;
  double strain = 0.0;
  double current = energy.energy(c, &strain, &out.min_J);
  if (!std::isfinite(current)) {
    // An inadmissible start (a larger load than the coefficients were solved for): the grid's
    // share off is admissible whenever u_0 is.
    r.setZero();
    c.setZero();
    current = energy.energy(c, &strain, &out.min_J);
    if (!std::isfinite(current)) {
      out.energy = current;
      return out;
    }
  }
  Eigen::VectorXd gradient;
  Eigen::SparseMatrix<double> hessian;
  ShiftedCholesky solver;
  const auto store = [&] {
    for (std::size_t l = 0; l < active.size(); ++l) C.row(active[l]) = c.segment<3>(3 * l).transpose();
  };
  // The load the residual is measured against: the external forces, or (a prescribed displacement
  // alone) the internal forces of the start.
  double load = energy.externalNorm();
  int rounding_steps = 0;
  for (int it = 0;; ++it) {
    auto start = std::chrono::steady_clock::now();
    energy.derivatives(c, gradient, hessian);
    unknowns.project(gradient, hessian);
    out.assembly_seconds += secondsSince(start);
    if (it == 0) load = std::max(load, gradient.norm());
    out.residual = load > 0 ? gradient.norm() / load : 0.0;
    if (config.on_iteration) {
      try {
        config.on_iteration(it, current, out.residual);
      } catch (...) {
        store();
        throw;
      }
    }
    if (out.residual <= config.residual_tolerance) {
      out.converged = true;
      break;
    }
    if (it >= config.max_iterations) break;
    start = std::chrono::steady_clock::now();
    const Eigen::VectorXd step = solver.solve(hessian, -gradient, config.initial_shift);
    out.factorisation_seconds += secondsSince(start);
    const double decrement = -gradient.dot(step);
    if (!(decrement > 0) || !std::isfinite(decrement)) break;
    // Near the minimum the energy cannot resolve a Newton step (its decrease is below the rounding
    // of the energy): the full step is taken on the residual's word, if it stays admissible.
    if (decrement <= config.tolerance * std::max(std::abs(current), strain)) {
      double trial_strain = 0.0, trial_J = 0.0;
      const Eigen::VectorXd trial = r + step;
      const Eigen::VectorXd trial_c = unknowns.full(trial);
      const double e = energy.energy(trial_c, &trial_strain, &trial_J);
      if (!std::isfinite(e) || ++rounding_steps > 3) break;
      r = trial;
      c = trial_c;
      current = e;
      strain = trial_strain;
      out.min_J = trial_J;
      ++out.iterations;
      continue;
    }
    // Backtracking (Armijo) line search; inverted states have infinite energy and are rejected.
    bool moved = false;
    start = std::chrono::steady_clock::now();
    for (double alpha = 1.0; alpha > 1e-6; alpha *= 0.5) {
      const Eigen::VectorXd trial = r + alpha * step;
      const Eigen::VectorXd trial_c = unknowns.full(trial);
      double trial_strain = 0.0, trial_J = 0.0;
      const double e = energy.energy(trial_c, &trial_strain, &trial_J);
      if (std::isfinite(e) && e <= current - 1e-4 * alpha * decrement) {
        r = trial;
        c = trial_c;
        current = e;
        strain = trial_strain;
        out.min_J = trial_J;
        moved = true;
        break;
      }
    }
    out.line_search_seconds += secondsSince(start);
    ++out.iterations;
    if (!moved) break;
  }
  store();
  out.energy = current;
  out.strain_energy = strain;
  return out;
}

}  // namespace demnerf::mechanics
