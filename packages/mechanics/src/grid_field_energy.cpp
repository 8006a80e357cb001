#include "grid_field_energy.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "demnerf/core/error.hpp"
#include "dense_kernels.hpp"
#include "parallel_for.hpp"

namespace demnerf::mechanics {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// A point's tangent is "strongly" indefinite below -kStrongTangentShare mu: the NeRF T-bar's moved
// start at 7.88 mm had 80 such points of 159,655 (the twist's shear makes 91 % of them mildly
// indefinite, all of which projected took one more Newton iteration: the projection stiffens the
// body's every point a little, so the first step undershoots).
constexpr double kStrongTangentShare = 0.1;

// The tangent A, or where it is strongly indefinite (A + tolerance I not positive definite) the
// positive semidefinite matrix nearest it (negative eigenvalues set to zero). A Neo-Hookean tangent
// is indefinite wherever F compresses a plane (its "flip" modes): mildly (-mu gamma / 2) under a
// twist's shear, which the body's other modes outweigh, strongly (-0.5 mu at det F 0.83) where a
// field moved from a coarser grid squeezes a cut cell's corner.
Tangent projectedTangent(const Tangent& A, double tolerance) {
  if (Eigen::LLT<Tangent>(A + tolerance * Tangent::Identity()).info() == Eigen::Success) return A;
  const Eigen::SelfAdjointEigenSolver<Tangent> eigen(0.5 * (A + A.transpose()));
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
}
}  // namespace

struct GridFieldEnergy::CellStiffness {
  explicit CellStiffness(int support) : S(support) {}
  int S;
  Eigen::MatrixXd K[3][3];
  Eigen::MatrixXd G[3];  // S x 3n: row s holds Grad phi_(s,i) of each point of the cell
  Eigen::MatrixXd H;     // 3n x S: the tangent's (i, j) block times G[j]^T, point by point
  Eigen::MatrixXd EK, reduced;  // a cut cell's K E, and E^T K E before it replaces K
  std::vector<Tangent> A;
  double at(int i, int j, long s, long t) const { return i >= j ? K[i][j](s, t) : K[j][i](t, s); }
};

GridFieldEnergy::GridFieldEnergy(const GridFieldProblem& problem, const HyperelasticMaterial& material,
                                 const BsplineGrid& grid, int threads)
    : pb_(problem), material_(material), grid_(grid), S_(grid.supportSize()), threads_(assemblyThreads(threads)) {
  const std::size_t n = problem.points.size(), ns = problem.surface_points.size();
  if (problem.volume.size() != n || problem.offset.size() != n || problem.grad_offset.size() != n ||
      problem.D.size() != n || problem.grad_D.size() != n || problem.body.size() != n ||
      problem.surface_offset.size() != ns || problem.surface_D.size() != ns || problem.surface_force.size() != ns)
    throw core::Error("grid field problem: per-point arrays differ in length");
  evaluateBasis();
  buildWork();
}

// Points in cell order, the basis at them (phi_i = D_i N, Grad phi_i = N Grad D_i + D_i Grad N),
// and the active nodes: those some point sees.
void GridFieldEnergy::evaluateBasis() {
  const long n = static_cast<long>(pb_.points.size());
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0L);
  std::vector<long> cell(n);
  for (long p = 0; p < n; ++p) cell[p] = grid_.cellIndex(pb_.points[p]);
  std::stable_sort(order_.begin(), order_.end(), [&](long a, long b) { return cell[a] < cell[b]; });
  for (long q = 0; q < n; ++q)
    if (q == 0 || cell[order_[q]] != cell[order_[q - 1]]) cell_start_.push_back(q);
  cell_start_.push_back(n);
  nodes_.resize(n * S_);
  phi_.resize(n * S_);
  grad_phi_.resize(n * S_);
  std::vector<double> N(S_);
  std::vector<Eigen::Vector3d> dN(S_);
  std::vector<char> seen(grid_.nodeCount(), 0);
  for (long q = 0; q < n; ++q) {
    const long p = order_[q];
    grid_.evaluate(pb_.points[p], &nodes_[q * S_], N.data(), dN.data());
    for (int s = 0; s < S_; ++s) {
      Eigen::Vector3d v;
      Eigen::Matrix3d g;
      for (int i = 0; i < 3; ++i) {
        v(i) = pb_.D[p](i) * N[s];
        g.row(i) = N[s] * pb_.grad_D[p].row(i) + pb_.D[p](i) * dN[s].transpose();
      }
      phi_[q * S_ + s] = v;
      grad_phi_[q * S_ + s] = g;
      if (v.squaredNorm() > 0 || g.squaredNorm() > 0) seen[nodes_[q * S_ + s]] = 1;
    }
  }
  local_.assign(grid_.nodeCount(), -1);
  for (long a = 0; a < grid_.nodeCount(); ++a)
    if (seen[a]) {
      local_[a] = static_cast<long>(active_.size());
      active_.push_back(a);
    }
  surface_nodes_.resize(pb_.surface_points.size() * S_);
  surface_phi_.resize(pb_.surface_points.size() * S_);
  for (std::size_t q = 0; q < pb_.surface_points.size(); ++q) {
    grid_.evaluate(pb_.surface_points[q], &surface_nodes_[q * S_], N.data(), dN.data());
    for (int s = 0; s < S_; ++s) surface_phi_[q * S_ + s] = pb_.surface_D[q] * N[s];
  }
}

// External work per full unknown and the offset's share.
void GridFieldEnergy::buildWork() {
  external_ = Eigen::VectorXd::Zero(unknowns());
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

// Each cell's way to the unknowns: its local nodes themselves where all of them are unknowns (the
// cells inside the body), else the extension's rows of its local nodes over the unknown nodes they
// reach.
void GridFieldEnergy::setUnknownMap(const Eigen::SparseMatrix<double>& node_map) {
  const bool identity = node_map.size() == 0;
  const Eigen::SparseMatrix<double, Eigen::RowMajor> rows = node_map;
  // Active node l is unknown node `reduced` itself (an identity row)?
  const auto plain = [&](long l, long& reduced) {
    if (identity) {
      reduced = l;
      return true;
    }
    const int k = rows.outerIndexPtr()[l];
    if (rows.outerIndexPtr()[l + 1] - k != 1 || rows.valuePtr()[k] != 1.0) return false;
    reduced = rows.innerIndexPtr()[k];
    return true;
  };
  reductions_.assign(cells(), {});
  for (long cell = 0; cell < cells(); ++cell) {
    CellReduction& r = reductions_[cell];
    const long* local_nodes = &nodes_[cell_start_[cell] * S_];
    bool all_plain = true;
    r.nodes.assign(S_, -1);
    for (int s = 0; s < S_ && all_plain; ++s) {
      const long l = local_[local_nodes[s]];
      all_plain = l < 0 || plain(l, r.nodes[s]);
    }
    if (all_plain) continue;
    r.nodes.clear();
    for (int s = 0; s < S_; ++s)
      if (const long l = local_[local_nodes[s]]; l >= 0)
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(rows, l); it; ++it)
          r.nodes.push_back(it.col());
    std::sort(r.nodes.begin(), r.nodes.end());
    r.nodes.erase(std::unique(r.nodes.begin(), r.nodes.end()), r.nodes.end());
    r.map = Eigen::MatrixXd::Zero(S_, static_cast<long>(r.nodes.size()));
    for (int s = 0; s < S_; ++s)
      if (const long l = local_[local_nodes[s]]; l >= 0)
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(rows, l); it; ++it)
          r.map(s, std::lower_bound(r.nodes.begin(), r.nodes.end(), it.col()) - r.nodes.begin()) = it.value();
  }
  neighbours_.assign(identity ? active_.size() : static_cast<std::size_t>(node_map.cols()), {});
  buildPattern();
}

// The Hessian's lower triangle: unknown node b's column block holds b itself (from the column's
// own component down) and the unknown nodes a > b that share a cell with it, in ascending order.
void GridFieldEnergy::buildPattern() {
  for (const CellReduction& r : reductions_)
    for (long b : r.nodes)
      if (b >= 0)
        for (long a : r.nodes)
          if (a >= b) neighbours_[b].push_back(a);
  const long nodes = static_cast<long>(neighbours_.size());
  Eigen::VectorXi per_column(3 * nodes);
  for (long b = 0; b < nodes; ++b) {
    auto& nb = neighbours_[b];
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    if (nb.empty() || nb.front() != b) nb.insert(nb.begin(), b);  // a node no point sees keeps its pivot
    for (int j = 0; j < 3; ++j) per_column(3 * b + j) = rowOffset(j, static_cast<long>(nb.size()), 0);
  }
  pattern_.resize(3 * nodes, 3 * nodes);
  pattern_.reserve(per_column);
  for (long b = 0; b < nodes; ++b)
    for (int j = 0; j < 3; ++j)
      for (long a : neighbours_[b])
        for (int i = a == b ? j : 0; i < 3; ++i) pattern_.insert(3 * a + i, 3 * b + j) = 0.0;
  pattern_.makeCompressed();
}

double GridFieldEnergy::energy(const Eigen::VectorXd& c, double* strain, double* min_J) const {
  std::vector<double> internal(threads_, 0.0), jmin(threads_, kInf);
  parallelChunks(cells(), threads_, [&](int chunk, long begin, long end) {
    for (long q = cell_start_[begin]; q < cell_start_[end]; ++q) {
      const Eigen::Matrix3d F = deformationGradient(c, q);
      jmin[chunk] = std::min(jmin[chunk], F.determinant());
      internal[chunk] += pb_.volume[order_[q]] * material_.energy(F);
    }
  });
  const double total = std::accumulate(internal.begin(), internal.end(), 0.0);
  if (strain) *strain = total;
  if (min_J) *min_J = *std::min_element(jmin.begin(), jmin.end());
  return std::isfinite(total) ? total - work(c) : kInf;
}

// Per point, the first Piola stress against each basis function's gradient: assembleCell()'s
// gradient without the stiffness.
Eigen::VectorXd GridFieldEnergy::gradient(const Eigen::VectorXd& c) const {
  std::vector<Eigen::VectorXd> parts(threads_);
  parallelChunks(cells(), threads_, [&](int chunk, long begin, long end) {
    Eigen::VectorXd& g = parts[chunk];
    g.setZero(unknowns());
    for (long q = cell_start_[begin]; q < cell_start_[end]; ++q) {
      const Eigen::Matrix3d P = pb_.volume[order_[q]] * material_.stress(deformationGradient(c, q));
      for (int s = 0; s < S_; ++s)
        if (const long l = local_[nodes_[q * S_ + s]]; l >= 0)
          for (int i = 0; i < 3; ++i) g(3 * l + i) += P.row(i).dot(grad_phi_[q * S_ + s].row(i));
    }
  });
  Eigen::VectorXd out = -external_;
  for (const Eigen::VectorXd& g : parts)
    if (g.size() > 0) out += g;
  return out;
}

double GridFieldEnergy::fieldNorm(const Eigen::VectorXd& c, bool offset) const {
  double sum = 0.0;
  for (long q = 0; q < static_cast<long>(order_.size()); ++q) {
    const long p = order_[q];
    Eigen::Vector3d u = Eigen::Vector3d::Zero();
    if (offset) {
      u = pb_.offset[p];
    } else {
      for (int s = 0; s < S_; ++s)
        if (const long l = local_[nodes_[q * S_ + s]]; l >= 0) u += c.segment<3>(3 * l).cwiseProduct(phi_[q * S_ + s]);
    }
    sum += pb_.volume[p] * u.squaredNorm();
  }
  return std::sqrt(sum);
}

// Cells are assembled on threads_ threads, each into its own copy of the values and gradient.
void GridFieldEnergy::derivatives(const Eigen::VectorXd& c, Eigen::VectorXd& gradient,
                                  Eigen::SparseMatrix<double>& hessian, bool projected) const {
  if (reductions_.size() != static_cast<std::size_t>(cells()))
    throw core::Error("grid field energy: setUnknownMap() was not called before derivatives()");
  hessian = pattern_;
  // Per-thread accumulators, kept between iterations: a fresh T-bar-sized set is ~14 MB of page
  // faults per Newton iteration.
  std::vector<Eigen::VectorXd>& values = scratch_values_;
  std::vector<Eigen::VectorXd>& gradients = scratch_gradients_;
  values.resize(threads_);
  gradients.resize(threads_);
  std::vector<char> ran(threads_, 0);  // a short range runs on fewer chunks than threads
  parallelChunks(cells(), threads_, [&](int chunk, long begin, long end) {
    ran[chunk] = 1;
    values[chunk].setZero(pattern_.nonZeros());
    gradients[chunk].setZero(unknowns());
    CellStiffness K(S_);
    for (long cell = begin; cell < end; ++cell) {
      assembleCell(c, cell, projected, K, gradients[chunk]);
      scatter(K, reductions_[cell], values[chunk].data());
    }
  });
  Eigen::Map<Eigen::VectorXd> sum(hessian.valuePtr(), hessian.nonZeros());
  gradient = -external_;
  for (int t = 0; t < threads_; ++t) {
    if (!ran[t]) continue;
    sum += values[t];
    gradient += gradients[t];
  }
  // A component a fixture prescribes everywhere on a node's support (a plane-strain u_z = 0)
  // has an empty row and column: give it a unit pivot so the factorisation needs no shift. Its
  // gradient is zero, so it never moves.
  const Eigen::VectorXd diagonal = hessian.diagonal();
  const double mean = std::max(diagonal.cwiseAbs().mean(), std::numeric_limits<double>::min());
  for (Eigen::Index k = 0; k < hessian.rows(); ++k)
    if (diagonal(k) == 0.0) hessian.coeffRef(k, k) = mean;
}

// One cell: K = sum over its points of B^T A B, where B maps the cell's coefficients to Grad u.
// A basis function moves one component, so B is block-sparse; written per component pair the sum
// is one dense product G_i (A_ij G_j^T) over all the cell's points, a fifth of the dense B^T A B's
// work. Through the extension (a cut cell) the blocks become E^T K E.
void GridFieldEnergy::assembleCell(const Eigen::VectorXd& c, long cell, bool projected, CellStiffness& K,
                                   Eigen::VectorXd& gradient) const {
  const long q0 = cell_start_[cell], n = cell_start_[cell + 1] - q0;
  for (auto& G : K.G) G.resize(S_, 3 * n);
  K.A.resize(n);
  for (long k = 0; k < n; ++k) {
    const long q = q0 + k, p = order_[q];
    const Eigen::Matrix3d F = deformationGradient(c, q);
    const Eigen::Matrix3d P = material_.stress(F);
    K.A[k] = material_.tangent(F);
    if (projected) K.A[k] = projectedTangent(K.A[k], kStrongTangentShare * material_.mu());
    K.A[k] *= pb_.volume[p];
    for (int s = 0; s < S_; ++s) {
      const Eigen::Matrix3d& g = grad_phi_[q * S_ + s];
      const long l = local_[nodes_[q * S_ + s]];
      for (int i = 0; i < 3; ++i) {
        K.G[i].block<1, 3>(s, 3 * k) = g.row(i);
        if (l >= 0) gradient(3 * l + i) += pb_.volume[p] * P.row(i).dot(g.row(i));
      }
    }
  }
  K.H.resize(3 * n, S_);
  // The products G_i (A_ij G_j^T) are most of an assembly's work: dense_kernels.hpp (this CPU's code).
  const double* G[3] = {K.G[0].data(), K.G[1].data(), K.G[2].data()};
  double* out[6];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j <= i; ++j) {
      K.K[i][j].resize(S_, S_);
      out[i * (i + 1) / 2 + j] = K.K[i][j].data();
    }
  dense::cellStiffness(G, K.A.data()->data(), n, S_, K.H.data(), out);
  const Eigen::MatrixXd& E = reductions_[cell].map;
  if (E.size() == 0) return;
  const int r = static_cast<int>(E.cols());
  K.EK.resize(S_, r);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j <= i; ++j) {
      K.reduced.resize(r, r);
      dense::reduceBlock(E.data(), S_, r, K.K[i][j].data(), K.EK.data(), K.reduced.data());
      K.K[i][j].swap(K.reduced);
    }
}

Eigen::Matrix3d GridFieldEnergy::deformationGradient(const Eigen::VectorXd& c, long q) const {
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

// Adds a cell's stiffness into the lower pattern's values: each node pair once, in the column of
// the node that comes first.
void GridFieldEnergy::scatter(const CellStiffness& K, const CellReduction& reduction, double* values) const {
  const int* outer = pattern_.outerIndexPtr();
  const long count = static_cast<long>(reduction.nodes.size());
  for (long sb = 0; sb < count; ++sb) {
    const long b = reduction.nodes[sb];
    if (b < 0) continue;
    const auto& nb = neighbours_[b];
    // A cell's nodes mostly come in ascending order (a cut cell's always): the search for a's rank
    // in b's column starts from the last one found while they do.
    long last_a = -1, last_rank = 0;
    for (long sa = 0; sa < count; ++sa) {
      const long a = reduction.nodes[sa];
      if (a < b) continue;
      const auto from = nb.begin() + (a > last_a ? last_rank : 0);
      const long rank = std::lower_bound(from, nb.end(), a) - nb.begin();
      last_a = a;
      last_rank = rank;
      for (int j = 0; j < 3; ++j) {
        double* column = values + outer[3 * b + j];
        for (int i = rank == 0 ? j : 0; i < 3; ++i) column[rowOffset(j, rank, i)] += K.at(i, j, sa, sb);
      }
    }
  }
}

}  // namespace demnerf::mechanics
