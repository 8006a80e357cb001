// The DEM's displacement field: u = s g + D o c (z_MLP(X) + N(X) C) with its X-gradient, where g
// and D are the Dirichlet lift (dirichlet_lift.hpp), z_MLP the shared network
// (displacement_mlp.hpp) and N C the feature grid (bspline_grid.hpp).
#include <torch/torch.h>

#include "demnerf/core/error.hpp"
#include "dem_solver_impl.hpp"

namespace demnerf::mechanics {

using torch::Tensor;

Eigen::MatrixXd toEigen(const Tensor& t) {
  const Tensor c = t.to(torch::kFloat64).contiguous();
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  return Eigen::Map<const RowMajor>(c.data_ptr<double>(), c.size(0), c.size(1));
}

std::vector<Tensor> DemSolver::Impl::parameters() const {
  std::vector<Tensor> p = net.parameters();
  if (grid) p.push_back(grid_coef);
  return p;
}

DemSolver::Impl::GridSupport DemSolver::Impl::gridSupport(const std::vector<Eigen::Vector3d>& points) const {
  const long n = static_cast<long>(points.size()), S = grid->supportSize();
  GridSupport sp{torch::empty({n, S}, torch::kLong), torch::empty({n, S}, torch::kFloat64),
                 torch::empty({n, S, 3}, torch::kFloat64)};
  long* nodes = sp.nodes.data_ptr<long>();
  double* N = sp.N.data_ptr<double>();
  auto* dN = reinterpret_cast<Eigen::Vector3d*>(sp.dN.data_ptr<double>());
  for (long p = 0; p < n; ++p) grid->evaluate(points[p], nodes + p * S, N + p * S, dN + p * S);
  sp.N = sp.N.to(dtype);
  sp.dN = sp.dN.to(dtype);
  return sp;
}

// The grid's share N(X) C at the points of a support and, with `gradient`, its X-gradient
// [n, i, k] = d/dX_k of component i.
std::pair<Tensor, Tensor> DemSolver::Impl::gridField(const GridSupport& sp, bool gradient) const {
  const long n = sp.N.size(0), S = sp.N.size(1);
  const Tensor coef = grid_coef.index_select(0, sp.nodes.reshape({-1})).reshape({n, S, 3});
  const Tensor z = (sp.N.unsqueeze(2) * coef).sum(1);
  return {z, gradient ? torch::matmul(coef.transpose(1, 2), sp.dN) : Tensor()};
}

// C (nodes x 3) into the grid's parameter tensor (row-major, the solver's dtype).
void DemSolver::Impl::setGridCoefficients(const Eigen::MatrixXd& C) {
  torch::NoGradGuard guard;
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rows = C;
  grid_coef.copy_(torch::from_blob(const_cast<double*>(rows.data()), {rows.rows(), 3}, torch::kFloat64));
}

// In parametric mode the load fraction is the network's fourth input, normalised by the range's
// largest magnitude; otherwise there is none.
Tensor DemSolver::Impl::loadInput(const Tensor& x, double scale) const {
  return config.parametric.enabled ? torch::full({x.size(0), 1}, scale / load_input_scale, x.options()) : Tensor();
}

DisplacementMlp::Output DemSolver::Impl::hidden(const Tensor& x, bool jacobian, double scale) const {
  return net.hidden(x, loadInput(x, scale), jacobian ? 1 : 0);
}

// u and (optionally) Grad u [n, i, k] for a subset with its lift tensors (g, grad_g, D, grad_D).
// The feature grid's share comes from `support` when given (the fixed point sets), else from x;
// `with_grid` false leaves it out (the offset of the grid's Newton solve).
std::pair<Tensor, Tensor> DemSolver::Impl::displacement(const Tensor& x, const Tensor* lift, bool gradient,
                                                        double scale, const GridSupport* support,
                                                        bool with_grid) const {
  const DisplacementMlp::Output o = net.forward(x, loadInput(x, scale), gradient ? 1 : 0);
  Tensor z = o.value, dz = o.d1;
  if (grid && with_grid) {
    const auto [zg, dzg] = gridField(support ? *support : gridSupport(x), gradient);
    z = z + zg;
    if (gradient) dz = dz + dzg.transpose(1, 2);
  }
  // Parametric: u = s (g + D z(X, s)), so the rest state at s = 0 holds exactly and z stays O(1)
  // over the whole load range.
  const double amplitude = config.parametric.enabled ? out_scale * scale : out_scale;
  z = z * amplitude;
  Tensor gu;
  if (gradient) gu = dz.transpose(1, 2) * amplitude;
  if (config.boundary.kind == DemConfig::Boundary::kPenalty || !lift) return {z, gu};
  const Tensor u = scale * lift[0] + lift[2] * z;
  if (gradient) gu = scale * lift[1] + lift[3] * z.unsqueeze(2) + lift[2].unsqueeze(2) * gu;
  return {u, gu};
}

// Features [h, 1] of the last hidden layer at points (rows), and their X-gradients (3 rows each).
void DemSolver::Impl::basisAt(const Tensor& x, double scale, Eigen::MatrixXd& h, Eigen::MatrixXd* dh) const {
  const DisplacementMlp::Output o = hidden(x, dh != nullptr, scale);
  const long n = o.value.size(0), k = o.value.size(1);
  h.resize(n, k + 1);
  h.leftCols(k) = toEigen(o.value);
  h.col(k).setOnes();
  if (!dh) return;
  dh->resize(3 * n, k + 1);
  dh->leftCols(k) = toEigen(o.d1.reshape({3 * n, k}));
  dh->col(k).setZero();
}

double DemSolver::Impl::maxDisplacement(double scale) const {
  torch::NoGradGuard guard;
  auto [u, unused] = displacement(xv, lift_v, false, scale);
  return u.norm(2, 1).max().item<double>();
}

// The load fractions predict()/evaluate() may answer: the trained range (parametric) or the
// trained fraction.
void DemSolver::Impl::checkLoadScale(double load_scale) const {
  if (!std::isfinite(load_scale)) throw core::Error("DEM predict: the load scale is not finite");
  if (config.parametric.enabled && (load_scale < config.parametric.load_range_min - 1e-12 || load_scale > config.parametric.load_range_max + 1e-12))
    throw core::Error("DEM predict: load scale " + std::to_string(load_scale) + " lies outside the trained range [" +
                      std::to_string(config.parametric.load_range_min) + ", " + std::to_string(config.parametric.load_range_max) +
                      "]; retrain with a wider load range");
  if (!config.parametric.enabled && std::abs(load_scale - fraction) > 1e-12)
    throw core::Error("DEM predict: this network was trained for load fraction " + std::to_string(fraction) +
                      " only; train with parametric = true to predict other loads");
}

}  // namespace demnerf::mechanics
