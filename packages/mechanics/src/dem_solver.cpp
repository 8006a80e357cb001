// The one translation unit of the DEM that includes LibTorch.
#include "demnerf/mechanics/dem_solver.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>
#include <iostream>
#include <sstream>
#include <random>
#include <thread>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/output_layer_newton.hpp"
#include "demnerf/mechanics/particle_quadrature.hpp"
#include "adaptive_load_steps.hpp"
#include "torch_solver_support.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;
using torch_support::keepLargeAllocationsInHeap;
using torch_support::setBlasThreads;
using torch_support::toTensor;

// Row-major tensor (rows x cols) -> Eigen, in double.
Eigen::MatrixXd toEigen(const Tensor& t) {
  const Tensor c = t.to(torch::kFloat64).contiguous();
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  return Eigen::Map<const RowMajor>(c.data_ptr<double>(), c.size(0), c.size(1));
}

Tensor det3(const Tensor& F) {
  auto f = [&](int i, int j) { return F.select(1, i).select(1, j); };
  return f(0, 0) * (f(1, 1) * f(2, 2) - f(1, 2) * f(2, 1)) - f(0, 1) * (f(1, 0) * f(2, 2) - f(1, 2) * f(2, 0)) +
         f(0, 2) * (f(1, 0) * f(2, 1) - f(1, 1) * f(2, 0));
}

// The spacing of the interior particles: the cube root of the 90th percentile of the particle
// volumes (0 without volumes). Not the median: surface particles of sampled bodies carry partial
// volumes and can be the majority on slender ones (the demo's T-bar: median 4.4 mm on a 6 mm grid).
double interiorParticleSpacing(const core::ParticleCloud& cloud) {
  std::vector<double> volumes;
  for (double v : cloud.volumes)
    if (v > 0) volumes.push_back(v);
  if (volumes.empty()) return 0.0;
  const auto at = volumes.begin() + static_cast<long>(0.9 * (volumes.size() - 1));
  std::nth_element(volumes.begin(), at, volumes.end());
  return std::cbrt(*at);
}

}  // namespace

struct DemSolver::Impl {
  core::ParticleCloud cloud;
  core::Scenario scenario;
  DemConfig config;
  std::unique_ptr<HyperelasticMaterial> material;
  torch::Dtype dtype = torch::kFloat64;
  Eigen::Vector3d center, half;
  double length = 1.0, out_scale = 1.0, energy_scale = 1.0;
  std::vector<Tensor> weights, biases;
  Tensor inv_half;  // 1 / half extent, (3)
  // Particle subsets: volume particles (energy, body force), surface particles (traction) and,
  // in penalty mode, constrained particles. The volume particles are ordered fixed-first: the last
  // n_band of them lie near a fixture and are jittered during Adam.
  Tensor xv, vol, body, lift_v[4];
  long n_band = 0;
  std::vector<Eigen::Vector3d> band_points;  // nominal positions of the band particles
  std::vector<double> band_jitter;           // half cell size of each (0: not jittered)
  mutable std::mt19937 rng{1};
  Tensor xs, traction_area, lift_s[4];
  Tensor xc, fixed_value, fixed_mask;
  Tensor eye3, center_t;
  double fraction = 0.0;  // load fraction the network currently represents
  double load_input_scale = 1.0;  // parametric: largest |load fraction| of the trained range
  bool rescaled = false;  // the output amplitude was fitted (first solve only)
  std::vector<Eigen::Vector3d> last_good_positions;
  std::function<void(int)> progress;
  int progress_every = 0;
  // The caller's budget and listeners (setControl), the running solve's clock, the load fraction
  // of the last good state and the last grid Newton's outcome (energy and residual of the answer).
  SolveControl control;
  std::unique_ptr<SolveClock> clock;
  double done_fraction = 0.0;
  GridNewtonOutcome last_grid;

  std::string keptState() const {
    std::ostringstream text;
    text << "the state at load fraction " << done_fraction;
    return text.str();
  }
  // Progress and the stop checks of a running solve (a no-op outside solve()).
  void tick(const char* phase, double scale, int iterations, double energy, double residual) {
    if (!clock) return;
    SolveProgress p;
    p.phase = phase;
    p.load_fraction = scale;
    p.iteration = iterations;
    p.energy = energy;
    p.residual = residual;
    clock->report(p);
    clock->check(keptState());
  }
  // Feature grid (DemConfig::grid_cell): the basis, its coefficients (a parameter, in units of the
  // output scale like the MLP's output) and the supports of the fixed point sets.
  struct GridSupport {
    Tensor nodes, N, dN;  // [n, S] node indices, [n, S] values, [n, S, 3] X-gradients
  };
  std::unique_ptr<BsplineGrid> grid;
  Tensor grid_coef;
  GridSupport grid_v, grid_s;
  // The grid Newton's fixed quadrature (particles near fixtures split, DemConfig::grid_refine_band).
  std::vector<Eigen::Vector3d> gq_points;
  std::vector<double> gq_volume;
  DirichletLift gq_lift;
  Tensor gq_x, gq_lift_t[4];

  void reportProgress(int iterations) const {
    if (progress && progress_every > 0 && iterations % progress_every == 0) progress(iterations);
  }

  std::vector<Tensor> parameters() const {
    std::vector<Tensor> p;
    for (std::size_t l = 0; l < weights.size(); ++l) {
      p.push_back(weights[l]);
      p.push_back(biases[l]);
    }
    if (grid) p.push_back(grid_coef);
    return p;
  }

  GridSupport gridSupport(const std::vector<Eigen::Vector3d>& points) const {
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
  GridSupport gridSupport(const Tensor& x) const { return gridSupport(torch_support::toVectors(x)); }

  // The grid's share N(X) C at the points of a support and, with `gradient`, its X-gradient
  // [n, i, k] = d/dX_k of component i.
  std::pair<Tensor, Tensor> gridField(const GridSupport& sp, bool gradient) const {
    const long n = sp.N.size(0), S = sp.N.size(1);
    const Tensor coef = grid_coef.index_select(0, sp.nodes.reshape({-1})).reshape({n, S, 3});
    const Tensor z = (sp.N.unsqueeze(2) * coef).sum(1);
    return {z, gradient ? torch::matmul(coef.transpose(1, 2), sp.dN) : Tensor()};
  }

  Tensor normalise(const Tensor& x) const {
    return (x - center_t) * inv_half;
  }

  Tensor activate(const Tensor& a) const {
    if (config.activation == "tanh") return torch::tanh(a);
    if (config.activation == "sigmoid") return torch::sigmoid(a);
    if (config.activation == "softplus") return torch::softplus(a);
    return torch::sin(a);
  }
  Tensor activateDerivative(const Tensor& a, const Tensor& h) const {
    if (config.activation == "tanh") return 1 - h * h;
    if (config.activation == "sigmoid") return h * (1 - h);
    if (config.activation == "softplus") return torch::sigmoid(a);
    return torch::cos(a);
  }

  // The last hidden layer's activations h(X) and, with `jacobian`, dh[n, k, m] = d h_m / d X_k by
  // forward-mode propagation through the layers (cheaper than three reverse passes with
  // create_graph, and differentiable).
  // In parametric mode the load fraction is a fourth input, normalised by the range's largest
  // magnitude.
  std::pair<Tensor, Tensor> hidden(const Tensor& x, bool jacobian, double scale) const {
    Tensor h = normalise(x), dh;
    if (config.parametric)
      h = torch::cat({h, torch::full({x.size(0), 1}, scale / load_input_scale, h.options())}, 1);
    for (std::size_t l = 0; l + 1 < weights.size(); ++l) {
      const Tensor a = torch::addmm(biases[l], h, weights[l].t());
      if (jacobian) {
        dh = l == 0 ? (weights[0].narrow(1, 0, 3).t() * inv_half.unsqueeze(1))
                          .unsqueeze(0)
                          .expand({x.size(0), 3, weights[0].size(0)})
                    : torch::matmul(dh, weights[l].t());
      }
      h = activate(a);
      if (jacobian) dh = dh * activateDerivative(a, h).unsqueeze(1);
    }
    return {h, dh};
  }

  // z(X) = W h(X) + b and, with `jacobian`, dz[n, k, i] = d z_i / d X_k.
  std::pair<Tensor, Tensor> network(const Tensor& x, bool jacobian, double scale) const {
    auto [h, dh] = hidden(x, jacobian, scale);
    const Tensor& W = weights.back();
    return {torch::addmm(biases.back(), h, W.t()), jacobian ? torch::matmul(dh, W.t()) : Tensor()};
  }

  // u and (optionally) Grad u [n, i, k] for a subset with its lift tensors (g, grad_g, D, grad_D).
  // The feature grid's share comes from `support` when given (the fixed point sets), else from x;
  // `with_grid` false leaves it out (the offset of the grid's Newton solve).
  std::pair<Tensor, Tensor> displacement(const Tensor& x, const Tensor* lift, bool gradient, double scale,
                                         const GridSupport* support = nullptr, bool with_grid = true) const {
    auto [z, dz] = network(x, gradient, scale);
    if (grid && with_grid) {
      const auto [zg, dzg] = gridField(support ? *support : gridSupport(x), gradient);
      z = z + zg;
      if (gradient) dz = dz + dzg.transpose(1, 2);
    }
    // Parametric: u = s (g + D z(X, s)), so the rest state at s = 0 holds exactly and z stays O(1)
    // over the whole load range.
    const double amplitude = config.parametric ? out_scale * scale : out_scale;
    z = z * amplitude;
    Tensor gu;
    if (gradient) gu = dz.transpose(1, 2) * amplitude;
    if (config.boundary == DemConfig::Boundary::kPenalty || !lift) return {z, gu};
    const Tensor u = scale * lift[0] + lift[2] * z;
    if (gradient) gu = scale * lift[1] + lift[3] * z.unsqueeze(2) + lift[2].unsqueeze(2) * gu;
    return {u, gu};
  }

  Tensor strainEnergy(const Tensor& F, Tensor& J) const {
    J = det3(F);
    return torch_support::neoHookeanEnergyDensity(J, (F * F).sum({1, 2}), *material, scenario.material.model);
  }

  // Loss at load fraction `scale`: Pi / energy_scale (+ penalty). Sets the potential energy and min J.
  Tensor loss(double scale, double* energy, double* min_J, bool jitter = false) const {
    Tensor x = xv;
    Tensor lift_j[4];
    const Tensor* lift = lift_v;
    const GridSupport* support = grid ? &grid_v : nullptr;
    if (jitter && n_band > 0) {
      // Stochastic quadrature in the band next to the fixtures: every Adam step moves each of
      // those quadrature points within its cell (see DemConfig::jitter). The lift of the moved
      // points is analytic and costs ~0.1 us per point.
      const long nb = n_band, nf = xv.size(0) - nb;
      std::uniform_real_distribution<float> u01(-1.0f, 1.0f);
      Tensor xb = torch::empty({nb, 3}, torch::kFloat64);
      Tensor lb[4] = {torch::empty({nb, 3}, torch::kFloat64), torch::empty({nb, 3, 3}, torch::kFloat64),
                      torch::empty({nb, 3}, torch::kFloat64), torch::empty({nb, 3, 3}, torch::kFloat64)};
      double* px = xb.data_ptr<double>();
      double* pg = lb[0].data_ptr<double>();
      double* pgg = lb[1].data_ptr<double>();
      double* pd = lb[2].data_ptr<double>();
      double* pgd = lb[3].data_ptr<double>();
      Eigen::Vector3d g, D;
      Eigen::Matrix3d gg, gD;
      for (long i = 0; i < nb; ++i) {
        Eigen::Vector3d p = band_points[i];
        if (band_jitter[i] > 0) p += band_jitter[i] * Eigen::Vector3d(u01(rng), u01(rng), u01(rng));
        for (int c = 0; c < 3; ++c) px[3 * i + c] = p(c);
        if (config.boundary == DemConfig::Boundary::kExact) {
          dirichletLiftAt(scenario, p, length, g, gg, D, gD);
          for (int r = 0; r < 3; ++r) {
            pg[3 * i + r] = g(r);
            pd[3 * i + r] = D(r);
            for (int c = 0; c < 3; ++c) {
              pgg[9 * i + 3 * r + c] = gg(r, c);
              pgd[9 * i + 3 * r + c] = gD(r, c);
            }
          }
        }
      }
      x = torch::cat({xv.narrow(0, 0, nf), xb.to(dtype)});
      if (config.boundary == DemConfig::Boundary::kExact) {
        for (int k = 0; k < 4; ++k) lift_j[k] = torch::cat({lift_v[k].narrow(0, 0, nf), lb[k].to(dtype)});
        lift = lift_j;
      }
      support = nullptr;  // the jittered points' grid support is computed from x
    }
    auto [uv, gu] = displacement(x, lift, true, scale, support);
    const Tensor F = gu + eye3;
    Tensor J;
    const Tensor psi = strainEnergy(F, J);
    Tensor pi = (psi * vol).sum() - scale * (body * uv).sum();
    if (xs.size(0) > 0) {
      auto [us, unused] = displacement(xs, lift_s, false, scale, grid ? &grid_s : nullptr);
      pi = pi - scale * (traction_area * us).sum();
    }
    Tensor total = pi / energy_scale;
    if (config.boundary == DemConfig::Boundary::kPenalty && xc.size(0) > 0) {
      auto [uc, unused] = displacement(xc, nullptr, false, scale);
      const Tensor mse = ((uc - scale * fixed_value) * fixed_mask).pow(2).sum(1).mean();
      total = total + config.penalty_weight * mse / (out_scale * out_scale);
    }
    if (energy) *energy = pi.item<double>();
    if (min_J) *min_J = J.numel() ? J.min().item<double>() : 1.0;
    return total;
  }

  std::vector<Tensor> snapshot() const { return torch_support::snapshot(parameters()); }
  void restore(const std::vector<Tensor>& s) { torch_support::restore(parameters(), s); }

  // Energy (J) at the particles' nominal positions with the output amplitude multiplied by alpha;
  // NaN when a particle inverts.
  double energyWithAmplitude(double scale, double alpha) {
    torch::NoGradGuard guard;
    const double saved = out_scale;
    out_scale = saved * alpha;
    double e = 0, jmin = 0;
    const Tensor l = loss(scale, &e, &jmin);
    out_scale = saved;
    const double total = l.item<double>() * energy_scale;
    return std::isfinite(total) && jmin > 0 ? total : std::numeric_limits<double>::quiet_NaN();
  }

  // 1-D line search on the amplitude of the network's output: a parabola through alpha = 0, 1, 2
  // (or 0, 0.5, 1 when 2 inverts particles). Sets out_scale to the minimiser, clamped to [0.1, 10]
  // per call, so a badly guessed displacement scale is corrected in a few calls.
  void rescaleOutput(double scale) {
    const double p0 = energyWithAmplitude(scale, 0.0), p1 = energyWithAmplitude(scale, 1.0);
    double h = 1.0, p2 = energyWithAmplitude(scale, 2.0);
    if (!std::isfinite(p2)) {
      h = 0.5;
      p2 = p1;
      const double ph = energyWithAmplitude(scale, 0.5);
      // Points 0, h, 2h = 0, 0.5, 1.
      const double a = (p2 - 2 * ph + p0) / (2 * h * h), b = (ph - p0) / h - a * h;
      if (!(a > 0) || !std::isfinite(ph)) return;
      apply(-b / (2 * a));
      return;
    }
    if (!std::isfinite(p0) || !std::isfinite(p1)) return;
    const double a = (p2 - 2 * p1 + p0) / 2, b = p1 - p0 - a;
    apply(a > 0 ? -b / (2 * a) : 10.0);
  }
  void apply(double alpha) {
    if (!std::isfinite(alpha) || alpha <= 0) return;
    alpha = std::clamp(alpha, 0.1, 10.0);
    out_scale *= alpha;
    energy_scale *= alpha * alpha;
    if (config.verbose) std::cerr << "dem: output amplitude x" << alpha << " -> " << out_scale << " m\n";
  }

  double maxDisplacement(double scale) const {
    torch::NoGradGuard guard;
    auto [u, unused] = displacement(xv, lift_v, false, scale);
    return u.norm(2, 1).max().item<double>();
  }

  // The load fractions predict()/evaluate() may answer: the trained range (parametric) or the
  // trained fraction.
  void checkLoadScale(double load_scale) const {
    if (!std::isfinite(load_scale)) throw core::Error("DEM predict: the load scale is not finite");
    if (config.parametric && (load_scale < config.load_range_min - 1e-12 || load_scale > config.load_range_max + 1e-12))
      throw core::Error("DEM predict: load scale " + std::to_string(load_scale) + " lies outside the trained range [" +
                        std::to_string(config.load_range_min) + ", " + std::to_string(config.load_range_max) +
                        "]; retrain with a wider load range");
    if (!config.parametric && std::abs(load_scale - fraction) > 1e-12)
      throw core::Error("DEM predict: this network was trained for load fraction " + std::to_string(fraction) +
                        " only; train with parametric = true to predict other loads");
  }

  bool newtonEnabled() const {
    return config.output_newton && config.boundary == DemConfig::Boundary::kExact && !config.parametric;
  }

  // Features [h, 1] of the last hidden layer at points (rows), and their X-gradients (3 rows each).
  void basisAt(const Tensor& x, double scale, Eigen::MatrixXd& h, Eigen::MatrixXd* dh) const {
    auto [ht, dht] = hidden(x, dh != nullptr, scale);
    const long n = ht.size(0), k = ht.size(1);
    h.resize(n, k + 1);
    h.leftCols(k) = toEigen(ht);
    h.col(k).setOnes();
    if (!dh) return;
    dh->resize(3 * n, k + 1);
    dh->leftCols(k) = toEigen(dht.reshape({3 * n, k}));
    dh->col(k).setZero();
  }

  // Newton on the output layer with the hidden layers frozen (output_layer_newton.hpp): the best
  // field in the network's current basis, at the nominal quadrature points. The output scale is
  // kept (rescaling the weights to O(1) made Adam's next steps invert particles on the T-bar).
  void solveOutputLayer(double scale) {
    torch::NoGradGuard guard;
    OutputLayerProblem pb;
    basisAt(xv, scale, pb.h, &pb.dh);
    const long n = xv.size(0), m = pb.h.cols();
    pb.g = toEigen(lift_v[0]);
    pb.D = toEigen(lift_v[2]);
    pb.grad_g = toEigen(lift_v[1].reshape({n, 9}));
    pb.grad_D = toEigen(lift_v[3].reshape({n, 9}));
    pb.volume = toEigen(vol.unsqueeze(1)).col(0);
    pb.body = toEigen(body);
    if (xs.size(0) > 0) {
      basisAt(xs, scale, pb.surface_h, nullptr);
      pb.surface_g = toEigen(lift_s[0]);
      pb.surface_D = toEigen(lift_s[2]);
      pb.traction_area = toEigen(traction_area);
    } else {
      pb.surface_h.resize(0, m);
      pb.surface_g.resize(0, 3);
      pb.surface_D.resize(0, 3);
      pb.traction_area.resize(0, 3);
    }
    pb.output_scale = out_scale;
    pb.load_scale = scale;
    Eigen::MatrixXd W(3, m);
    W.leftCols(m - 1) = toEigen(weights.back());
    W.col(m - 1) = toEigen(biases.back().unsqueeze(1)).col(0);
    OutputLayerNewtonConfig newton;
    newton.max_iterations = config.newton_iterations;
    const OutputLayerNewtonOutcome outcome = minimiseOutputLayer(pb, *material, W, newton);
    const Tensor w = torch::from_blob(W.data(), {m, 3}, torch::kFloat64).t().to(dtype);  // column-major W
    weights.back().copy_(w.narrow(1, 0, m - 1));
    biases.back().copy_(w.select(1, m - 1));
    if (config.verbose)
      std::cerr << "dem: output-layer Newton " << outcome.iterations << " its, energy " << outcome.energy
                << (outcome.converged ? "" : " (not converged)") << ", output scale " << out_scale << " m\n";
  }

  // Newton on the feature grid's coefficients with the MLP frozen (grid_field_newton.hpp), on the
  // grid quadrature: the best field in MLP + grid with the MLP's share fixed.
  // False when Newton does not converge within grid_newton_iterations (the load step then counts as
  // failed and is halved).
  bool solveGrid(double scale, int& iterations) {
    torch::NoGradGuard guard;
    GridFieldProblem pb;
    pb.points = gq_points;
    pb.volume = gq_volume;
    pb.D = gq_lift.D;
    pb.grad_D = gq_lift.grad_D;
    for (double v : gq_volume) pb.body.push_back(scale * v * scenario.body_force);
    // Offset: everything but the grid (the lift and the MLP's share).
    const auto [u0, gu0] = displacement(gq_x, gq_lift_t, true, scale, nullptr, false);
    pb.offset = torch_support::toVectors(u0);
    const Tensor g = gu0.to(torch::kFloat64).contiguous();
    const double* pg = g.data_ptr<double>();
    pb.grad_offset.resize(gq_points.size());
    for (std::size_t p = 0; p < gq_points.size(); ++p)
      pb.grad_offset[p] = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pg + 9 * p);
    if (xs.size(0) > 0) {
      pb.surface_points = torch_support::toVectors(xs);
      pb.surface_offset = torch_support::toVectors(displacement(xs, lift_s, false, scale, nullptr, false).first);
      pb.surface_D = torch_support::toVectors(lift_s[2]);
      pb.surface_force = torch_support::toVectors(traction_area * scale);
    }
    // The Newton unknowns are in metres: c C.
    Eigen::MatrixXd C = toEigen(grid_coef.detach()) * out_scale;
    GridNewtonConfig newton;
    newton.max_iterations = config.grid_newton_iterations;
    const int before = iterations;
    newton.on_iteration = [&](int it, double energy, double residual) {
      tick("newton", scale, before + it, energy, residual);
    };
    GridNewtonOutcome outcome;
    try {
      outcome = minimiseGridField(pb, *material, *grid, C, newton);
    } catch (...) {
      setGridCoefficients(C / out_scale);
      throw;
    }
    iterations += outcome.iterations;
    last_grid = outcome;
    setGridCoefficients(C / out_scale);
    if (config.verbose)
      std::cerr << "dem: grid Newton " << outcome.iterations << " its, energy " << outcome.energy << ", min J "
                << outcome.min_J << ", residual " << outcome.residual << (outcome.converged ? "" : " (not converged)")
                << "; assembly "
                << outcome.assembly_seconds << " s, factorisation " << outcome.factorisation_seconds
                << " s, line search " << outcome.line_search_seconds << " s\n";
    return outcome.converged;
  }

  // C (nodes x 3) into the grid's parameter tensor (row-major, the solver's dtype).
  void setGridCoefficients(const Eigen::MatrixXd& C) {
    torch::NoGradGuard guard;
    const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rows = C;
    grid_coef.copy_(torch::from_blob(const_cast<double*>(rows.data()), {rows.rows(), 3}, torch::kFloat64));
  }

  // The grid Newton's quadrature: the particles' own volumes (midpoint rule) with a small share on
  // the surface particles (DemConfig::grid_surface_share), interior particles near a fixture or
  // load split into 2 x 2 x 2 sub-points of their cube (Newton has no jitter to catch a ramp
  // between a region and the first particle layer).
  void buildGridQuadrature() {
    if (config.grid_quadrature == DemConfig::GridQuadrature::kCells) {
      CellQuadratureConfig cq;
      cq.points_per_axis = config.grid_gauss_points;
      cq.boundary_levels = config.grid_boundary_levels;
      CellQuadrature q = cellQuadrature(cloud, *grid, cq);
      gq_points = std::move(q.points);
      gq_volume = std::move(q.weights);
    } else {
      buildParticleGridQuadrature();
    }
    gq_lift = dirichletLift(scenario, gq_points, length);
    gq_x = toTensor(gq_points, dtype);
    gq_lift_t[0] = toTensor(gq_lift.g, dtype);
    gq_lift_t[1] = toTensor(gq_lift.grad_g, dtype);
    gq_lift_t[2] = toTensor(gq_lift.D, dtype);
    gq_lift_t[3] = toTensor(gq_lift.grad_D, dtype);
  }

  void buildParticleGridQuadrature() {
    // (1 - f) volumes + f energyWeights: both sum to the body's volume, so a homogeneous state
    // keeps its exact energy.
    const double f = config.grid_surface_share;
    std::vector<double> weight = cloud.volumes;
    if (f > 0) {
      const std::vector<double> shared = energyWeights(cloud);
      for (std::size_t i = 0; i < weight.size(); ++i) weight[i] = (1 - f) * weight[i] + f * shared[i];
    }
    gq_points.clear();
    gq_volume.clear();
    const double band = config.grid_refine_band * config.grid_cell;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!(weight[i] > 0)) continue;
      const Eigen::Vector3d& x = cloud.positions[i];
      const double half = 0.5 * std::cbrt(cloud.volumes[i]);
      // Near a region's boundary: within the band outside it, or a cube that reaches out of it
      // (deep inside a fixture the field is prescribed: no ramp to catch).
      const auto near = [&](const core::Region& region) {
        for (int c = 0; c < 8; ++c)
          if (!region.contains(x + half * Eigen::Vector3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1)))
            return regionDistance(region, x) <= band;
        return false;
      };
      bool split = false;
      for (const core::Fixture& f : scenario.fixtures) split = split || near(f.region);
      for (const core::Load& l : scenario.loads) split = split || near(l.region);
      if (cloud.volumes[i] > 0 && !cloud.isSurface(i) && split) {
        const double quarter = 0.5 * half;
        for (int c = 0; c < 8; ++c) {
          gq_points.push_back(x + quarter * Eigen::Vector3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1));
          gq_volume.push_back(weight[i] / 8);
        }
      } else {
        gq_points.push_back(x);
        gq_volume.push_back(weight[i]);
      }
    }
  }

  // Parametric mode: one Adam run over the whole load range. Each step draws
  // parametric_samples load fractions (stratified over the range) and minimises the sum of their
  // potential energies, each divided by its own scale (energy grows with the load squared), so
  // small and large loads are learnt alike. False when a sample inverts particles or turns NaN.
  bool trainParametric(int& iterations) {
    const double lo = config.load_range_min, hi = config.load_range_max;
    const double floor = 0.05 * load_input_scale;  // keeps samples near 0 from dominating
    const int k = std::max(1, config.parametric_samples);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    fraction = 1.0;  // what predict() shows from a progress callback
    torch::optim::Adam adam(parameters(), torch::optim::AdamOptions(config.adam_learning_rate));
    const int n = std::max(1, config.adam_iterations);
    const double decay = std::pow(std::max(config.adam_final_rate_ratio, 1e-6), 1.0 / std::max(1, n - 1));
    double lr = config.adam_learning_rate;
    for (int it = 0; it < n; ++it) {
      adam.zero_grad();
      Tensor total;
      for (int j = 0; j < k; ++j) {
        const double s = lo + (hi - lo) * (j + u01(rng)) / k;
        double jmin = 0;
        Tensor l = loss(s, nullptr, &jmin, config.jitter) / (s * s + floor * floor);
        if (!std::isfinite(l.item<double>()) || !(jmin > 0)) return false;
        if (j == 0) tick("adam", s, iterations, l.item<double>() * energy_scale * (s * s + floor * floor),
                         std::numeric_limits<double>::quiet_NaN());
        total = j == 0 ? l : total + l;
      }
      (total / k).backward();
      adam.step();
      lr *= decay;
      for (auto& group : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
      reportProgress(++iterations);
    }
    // The trained field must be admissible over the whole range, not only at the samples drawn.
    torch::NoGradGuard guard;
    for (int j = 0; j <= 8; ++j) {
      double jmin = 0;
      const Tensor l = loss(lo + (hi - lo) * j / 8.0, nullptr, &jmin);
      if (!std::isfinite(l.item<double>()) || !(jmin > 0)) return false;
    }
    return true;
  }

  std::string gridFailureAdvice() const {
    std::ostringstream text;
    text << "The feature grid's Newton solve (cells of " << config.grid_cell << " m) did not reach an equilibrium"
         << (last_grid.min_J > 0 ? "" : " or inverted the material") << " (last residual " << last_grid.residual
         << ", smallest det F " << last_grid.min_J
         << "). Likely causes: a load too large for the material (try a smaller load or more load_steps), a fixture "
            "that holds too little of the body, or a grid too coarse for the body's thinnest part (raise "
            "grid_body_cells or lower grid_cell); grid_newton_iterations raises the iteration cap.";
    return text.str();
  }

  // The equilibrium checks an answer must pass before solve() reports success: the grid Newton's
  // first-order condition, and a potential energy no higher than the undeformed state's (0 J when
  // no fixture prescribes a displacement: any minimiser does at least as well as u = 0).
  void checkAnswer(const DemReport& report) const {
    if (grid && !(last_grid.converged && report.residual <= 10 * GridNewtonConfig{}.residual_tolerance))
      throw SolveError(SolveFailure::kNotConverged,
                       "DEM: the answer is not an equilibrium (relative residual " + std::to_string(report.residual) +
                           "); " + gridFailureAdvice());
    bool prescribed = false;
    for (const core::Fixture& f : scenario.fixtures) prescribed = prescribed || f.displacement.norm() > 0;
    const double slack = 1e-9 * energy_scale + 1e-12;
    if (!prescribed && !(report.energy <= slack))
      throw SolveError(SolveFailure::kNotConverged,
                       "DEM: the answer's potential energy " + std::to_string(report.energy) +
                           " J is above the undeformed state's 0 J, so it is no minimum under these dead loads; " +
                           (grid ? gridFailureAdvice() : std::string("train longer (adam_iterations) or use the feature grid")));
  }

  // Trains at one load fraction; false when the loss turns NaN or a particle inverts.
  bool train(double scale, int& iterations, DemReport& report) {
    auto params = parameters();
    double e = 0, jmin = 0;
    fraction = scale;  // what predict() shows from a progress callback
    const bool newton = newtonEnabled();
    if (newton) solveOutputLayer(scale);
    if (grid && !solveGrid(scale, iterations)) return false;
    if (config.adam_iterations > 0) {
      torch::optim::Adam adam(params, torch::optim::AdamOptions(config.adam_learning_rate));
      const int n = config.adam_iterations;
      const double decay = std::pow(std::max(config.adam_final_rate_ratio, 1e-6), 1.0 / std::max(1, n - 1));
      double lr = config.adam_learning_rate;
      for (int it = 0; it < n; ++it) {
        if (!newton && !grid && !rescaled && config.rescale_every > 0 && it > 0 && it % config.rescale_every == 0 &&
            it <= config.rescale_until && config.boundary == DemConfig::Boundary::kExact)
          rescaleOutput(scale);
        adam.zero_grad();
        Tensor l = loss(scale, nullptr, &jmin, config.jitter);
        const double value = l.item<double>();
        if (!std::isfinite(value) || !(jmin > 0)) return false;
        tick("adam", scale, iterations, value * energy_scale, std::numeric_limits<double>::quiet_NaN());
        l.backward();
        adam.step();
        lr *= decay;
        for (auto& group : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
        reportProgress(++iterations);
        if (newton && config.newton_every > 0 && (it + 1) % config.newton_every == 0 && it + 1 < n)
          solveOutputLayer(scale);
      }
      rescaled = true;
    }
    if (newton) solveOutputLayer(scale);
    if (grid && config.adam_iterations > 0 && !solveGrid(scale, iterations)) return false;
    if (config.lbfgs_iterations > 0) {
      const auto before = snapshot();
      double e_before = 0;
      {
        torch::NoGradGuard guard;
        loss(scale, &e_before, nullptr);
      }
      const double u_before = maxDisplacement(scale);
      torch::optim::LBFGS lbfgs(params, torch::optim::LBFGSOptions(1.0)
                                            .max_iter(config.lbfgs_iterations)
                                            .max_eval(config.lbfgs_iterations * 5 / 4)
                                            .history_size(config.lbfgs_history)
                                            .tolerance_grad(1e-12)
                                            .tolerance_change(config.tolerance)
                                            .line_search_fn("strong_wolfe"));
      auto closure = [&]() -> Tensor {
        lbfgs.zero_grad();
        double jm = 0;
        Tensor l = loss(scale, nullptr, &jm);
        reportProgress(++iterations);
        tick("lbfgs", scale, iterations, l.item<double>() * energy_scale, std::numeric_limits<double>::quiet_NaN());
        if (!std::isfinite(l.item<double>()) || !(jm > 0)) {
          // Tell the line search this point is unacceptable without poisoning its history.
          return torch::full({}, 1e30, torch::TensorOptions().dtype(dtype));
        }
        l.backward();
        return l;
      };
      lbfgs.step(closure);
      double e_after = 0, jm = 0;
      {
        torch::NoGradGuard guard;
        loss(scale, &e_after, &jm);
      }
      const double u_after = maxDisplacement(scale);
      const bool exploit = !std::isfinite(e_after) || !(jm > 0) ||
                           e_after < e_before - config.polish_max_energy_drop * std::abs(e_before) ||
                           u_after > config.polish_max_growth * u_before || u_after > length;
      if (exploit) {
        if (config.verbose)
          std::cerr << "dem: L-BFGS polish rejected (energy " << e_before << " -> " << e_after << ", max |u| "
                    << u_before << " -> " << u_after << ")\n";
        restore(before);
        report.polish_rejected = true;
      } else if (config.verbose) {
        std::cerr << "dem: L-BFGS polish energy " << e_before << " -> " << e_after << "\n";
      }
    }
    torch::NoGradGuard guard;
    Tensor l = loss(scale, &e, &jmin);
    for (const Tensor& p : parameters())
      if (!torch::isfinite(p).all().item<bool>()) return false;
    return std::isfinite(l.item<double>()) && jmin > 0;
  }
};

DemSolver::DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  validateProblem(scenario, cloud);
  if (config.width < 1 || config.depth < 1) throw core::Error("DEM network needs width >= 1 and depth >= 1");
  if (config.activation != "tanh" && config.activation != "sigmoid" && config.activation != "softplus" &&
      config.activation != "sin")
    throw core::Error("unknown DEM activation '" + config.activation + "': use tanh, sigmoid, softplus or sin");
  if (config.parametric && !(std::isfinite(config.load_range_min) && std::isfinite(config.load_range_max) &&
                             config.load_range_min < config.load_range_max && config.load_range_min <= 1.0 &&
                             config.load_range_max >= 1.0))
    throw core::Error("DEM parametric load range [" + std::to_string(config.load_range_min) + ", " +
                      std::to_string(config.load_range_max) +
                      "] must be finite, ordered and contain 1 (the scenario's own load, which result() reports)");
  if (config.grid_cell < 0 || !std::isfinite(config.grid_cell) || config.grid_spacings < 0 ||
      !std::isfinite(config.grid_spacings) || !(config.grid_body_cells >= 0) || !std::isfinite(config.grid_body_cells))
    throw core::Error("DEM grid_cell, grid_spacings and grid_body_cells must be finite and >= 0 (0: no feature grid)");
  if (!(config.grid_surface_share >= 0 && config.grid_surface_share <= 1) || !(config.grid_refine_band >= 0) ||
      !std::isfinite(config.grid_refine_band))
    throw core::Error("DEM grid_surface_share must lie in [0, 1] and grid_refine_band be finite and >= 0");
  const double spacing = interiorParticleSpacing(cloud);
  if (config.grid_cell == 0 && config.grid_spacings > 0) config.grid_cell = config.grid_spacings * spacing;
  if (config.grid_cell == 0 && config.grid_body_cells > 0) {
    double volume = 0.0;
    for (double v : cloud.volumes) volume += std::max(v, 0.0);
    // Never finer than the particles, which resolve the body's shape and carry its loads.
    config.grid_cell = std::max(std::cbrt(volume / config.grid_body_cells), spacing);
  }
  if (config.grid_cell > 0 && (config.parametric || config.boundary != DemConfig::Boundary::kExact ||
                               config.output_newton))
    throw core::Error(
        "the DEM feature grid (grid_cell > 0) needs the exact boundary mode and works without parametric mode and "
        "the output-layer Newton; turn those off or set grid_cell = 0");
  if (config.grid_cell > 0 && config.grid_quadrature == DemConfig::GridQuadrature::kParticles) {
    // The particles are the grid's quadrature: a cell of about one particle spacing has modes the
    // particles cannot see, and Newton finds them (a twisted bar: 80 % error at 1 spacing).
    if (config.grid_cell < 1.5 * spacing)
      throw core::Error("DEM grid_cell " + std::to_string(config.grid_cell) + " m is below 1.5 particle spacings (" +
                        std::to_string(spacing) + " m): the particles cannot integrate the grid's finer modes; use " +
                        "about two spacings (" + std::to_string(2 * spacing) + " m) or more");
  }
  if (config.grid_cell > 0 && config.grid_quadrature == DemConfig::GridQuadrature::kCells &&
      config.grid_cell < spacing)
    // The cells' quadrature resolves the body to about one particle spacing, and the loads act on
    // the surface particles: finer cells than that would see single particles as point loads.
    throw core::Error("DEM grid_cell " + std::to_string(config.grid_cell) + " m is finer than the particle spacing (" +
                      std::to_string(spacing) + " m), which resolves the body and its loads; use a coarser cell " +
                      "or finer particles");
  if (config.load_steps < 0) throw core::Error("DEM load_steps must be >= 0 (0: the scenario's)");
  m.config = config;
  m.dtype = config.double_precision ? torch::kFloat64 : torch::kFloat32;
  // One thread is fastest for product-size clouds on shared 2-core machines (notes/dem_speed.md);
  // large clouds amortise the threads' synchronisation.
  const int threads = config.threads > 0 ? config.threads
                      : cloud.size() < 50000 ? 1
                                             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  at::set_num_threads(threads);
  setBlasThreads(threads);
  if (config.tune_allocator) keepLargeAllocationsInHeap();
  m.cloud = std::move(cloud);
  torch::manual_seed(config.seed);
  Eigen::Vector3d lo = m.cloud.positions[0], hi = lo;
  for (const auto& p : m.cloud.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  m.center = 0.5 * (lo + hi);
  m.half = (0.5 * (hi - lo)).cwiseMax(1e-9 * (hi - lo).norm() + 1e-12);
  m.length = (hi - lo).maxCoeff();
  m.load_input_scale = std::max(std::abs(config.load_range_min), std::abs(config.load_range_max));
  m.inv_half = toTensor(std::vector<Eigen::Vector3d>{m.half.cwiseInverse()}, m.dtype).squeeze(0);
  m.center_t = toTensor(std::vector<Eigen::Vector3d>{m.center}, m.dtype);
  m.eye3 = torch::eye(3, torch::TensorOptions().dtype(m.dtype)).unsqueeze(0);
  m.rng.seed(static_cast<unsigned>(config.seed));
  int in = config.parametric ? 4 : 3;
  for (int l = 0; l <= config.depth; ++l) {
    const int out = l == config.depth ? 3 : config.width;
    const double bound = std::sqrt(6.0 / (in + out));
    Tensor W = (torch::rand({out, in}, torch::TensorOptions().dtype(m.dtype)) * 2 - 1) * bound;
    Tensor b = torch::zeros({out}, torch::TensorOptions().dtype(m.dtype));
    // The output layer starts at zero: training begins from u = g (the rest state or the lift).
    if (l == config.depth) W.zero_();
    m.weights.push_back(W.requires_grad_(true));
    m.biases.push_back(b.requires_grad_(true));
    in = out;
  }
  if (config.grid_cell > 0) {
    // The cell quadrature gets half a spacing of margin: a lattice cloud whose outer particles
    // carry whole cells of volume describes a body that far beyond its particles
    // (cell_quadrature.hpp moves the surface out). The particle quadrature stays on the particles:
    // nodes seen only at the edge of their support would be near-singular.
    const double pad = config.grid_quadrature == DemConfig::GridQuadrature::kCells ? 0.5 * spacing : 0.0;
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(pad);
    m.grid = std::make_unique<BsplineGrid>(lo - margin, hi + margin, config.grid_cell, config.grid_degree);
    if (m.grid->nodeCount() > 4000000)
      throw core::Error("DEM feature grid of " + std::to_string(m.grid->nodeCount()) + " nodes: grid_cell " +
                        std::to_string(config.grid_cell) + " m is far too fine for a body of " +
                        std::to_string(m.length) + " m; use a cell of a few particle spacings");
    m.grid_coef = torch::zeros({m.grid->nodeCount(), 3}, torch::TensorOptions().dtype(m.dtype)).requires_grad_(true);
  }
  setScenario(scenario);
}

void DemSolver::setScenario(const core::Scenario& scenario) {
  Impl& m = *impl_;
  validateProblem(scenario, m.cloud);
  m.scenario = scenario;
  m.material = makeMaterial(scenario.material);
  const auto traction = particleTractions(scenario, m.cloud);
  const Dirichlet fixed = resolveFixtures(scenario, m.cloud.positions);
  const DirichletLift lift = dirichletLift(scenario, m.cloud.positions, m.length);
  // Jittered cells are sampled over their whole volume, which already covers the strip between the
  // outer particle layer and the surface: they keep their own volume (moving a share to surface
  // points would under-weight that strip and reopen a cheaper-than-physical surface layer; measured
  // on the uniaxial cube: energy 2 % below the exact minimum). Fixed quadrature needs the shares.
  const std::vector<double> weight = m.config.jitter ? m.cloud.volumes : energyWeights(m.cloud);
  std::vector<long> vi, si;
  double volume = 0.0, max_t = 0.0, max_g = 0.0;
  for (std::size_t i = 0; i < m.cloud.size(); ++i) {
    if (weight[i] > 0) vi.push_back(static_cast<long>(i));
    if (m.cloud.areas[i] > 0 && traction[i].squaredNorm() > 0) si.push_back(static_cast<long>(i));
    volume += m.cloud.volumes[i];
    max_t = std::max(max_t, traction[i].norm());
  }
  if (vi.empty()) throw core::Error("the particle cloud has no particle with volume > 0");
  // Fixed-first order: the band particles near a fixture go last (see DemConfig::jitter).
  std::vector<long> fixed_part, band_part;
  std::vector<double> half_cell(m.cloud.size(), 0.0);
  for (long i : vi) {
    const bool interior = m.cloud.volumes[i] > 0 && !m.cloud.isSurface(i);
    double near = std::numeric_limits<double>::infinity();
    if (interior) {
      half_cell[i] = 0.5 * std::cbrt(m.cloud.volumes[i]);
      for (const core::Fixture& f : scenario.fixtures) near = std::min(near, regionDistance(f.region, m.cloud.positions[i]));
    }
    (interior && m.config.jitter && near < m.config.jitter_band * 2 * half_cell[i] ? band_part : fixed_part).push_back(i);
  }
  vi = fixed_part;
  vi.insert(vi.end(), band_part.begin(), band_part.end());
  m.n_band = static_cast<long>(band_part.size());
  m.band_points.clear();
  m.band_jitter.clear();
  for (long i : band_part) {
    m.band_points.push_back(m.cloud.positions[i]);
    m.band_jitter.push_back(half_cell[i]);
  }
  for (const auto& v : fixed.value) max_g = std::max(max_g, v.norm());
  const auto pick = [&](const std::vector<long>& idx, const auto& all) {
    using T = typename std::decay_t<decltype(all)>::value_type;
    std::vector<T> out;
    for (long i : idx) out.push_back(all[i]);
    return toTensor(out, m.dtype);
  };
  std::vector<double> vols, zeros;
  std::vector<Eigen::Vector3d> body, ta;
  for (long i : vi) {
    vols.push_back(weight[i]);
    body.push_back(weight[i] * scenario.body_force);
  }
  for (long i : si) ta.push_back(m.cloud.areas[i] * traction[i]);
  m.xv = pick(vi, m.cloud.positions);
  m.vol = toTensor(vols, m.dtype);
  m.body = toTensor(body, m.dtype);
  m.xs = si.empty() ? torch::zeros({0, 3}, torch::TensorOptions().dtype(m.dtype)) : pick(si, m.cloud.positions);
  m.traction_area = si.empty() ? torch::zeros({0, 3}, torch::TensorOptions().dtype(m.dtype)) : toTensor(ta, m.dtype);
  m.lift_v[0] = pick(vi, lift.g);
  m.lift_v[1] = pick(vi, lift.grad_g);
  m.lift_v[2] = pick(vi, lift.D);
  m.lift_v[3] = pick(vi, lift.grad_D);
  if (!si.empty()) {
    m.lift_s[0] = pick(si, lift.g);
    m.lift_s[1] = pick(si, lift.grad_g);
    m.lift_s[2] = pick(si, lift.D);
    m.lift_s[3] = pick(si, lift.grad_D);
  }
  if (m.grid) {
    m.grid_v = m.gridSupport(m.xv);
    if (!si.empty()) m.grid_s = m.gridSupport(m.xs);
    m.buildGridQuadrature();
  }
  std::vector<long> ci(fixed.index.begin(), fixed.index.end());
  std::vector<Eigen::Vector3d> mask;
  for (const auto& k : fixed.mask) mask.push_back(k.cast<double>());
  m.xc = pick(ci, m.cloud.positions);
  m.fixed_value = toTensor(fixed.value, m.dtype);
  m.fixed_mask = toTensor(mask, m.dtype);
  // Scales: the network outputs O(1) for the expected displacement, and the loss is O(1) at the
  // expected strain, so optimiser tolerances mean the same thing for every body and load.
  // A trained network keeps its fitted amplitude (a better guess than the a-priori one); the next
  // solve refits it.
  const double E = scenario.material.youngs_modulus;
  if (!m.rescaled) {
    m.out_scale = std::max({max_g, m.length * (max_t + scenario.body_force.norm() * m.length) / E, 1e-6 * m.length});
    const double strain = m.out_scale / m.length;
    m.energy_scale = m.material->mu() * volume * strain * strain;
  }
  m.rescaled = false;
  m.fraction = 0.0;
}

DemReport DemSolver::solve() {
  Impl& m = *impl_;
  const auto start = std::chrono::steady_clock::now();
  DemReport report;
  m.clock = std::make_unique<SolveClock>(m.control, "dem");
  m.done_fraction = 0.0;
  m.last_grid = GridNewtonOutcome{};
  std::vector<Tensor> saved = m.snapshot();
  try {
    if (m.config.parametric) {
      if (!m.trainParametric(report.iterations)) {
        m.restore(saved);
        throw SolveError(SolveFailure::kInverted,
                         "DEM (parametric): training over load fractions [" + std::to_string(m.config.load_range_min) +
                             ", " + std::to_string(m.config.load_range_max) +
                             "] inverted particles (det F <= 0) or diverged (NaN); narrow the range or lower the "
                             "learning rate");
      }
      report.load_steps = 1;
    } else {
      report.load_steps = runAdaptiveLoadSteps(
          m.config.load_steps > 0 ? m.config.load_steps : m.grid ? 1 : m.scenario.load_steps, m.config.max_halvings,
          [&](double target) {
            saved = m.snapshot();
            const bool ok = m.train(target, report.iterations, report);
            if (ok) m.done_fraction = target;
            return ok;
          },
          [&](double done) {
            m.restore(saved);
            m.fraction = done;
          },
          "DEM", m.grid ? "" : "Use more load_steps or a smaller load.", m.config.verbose);
    }
  } catch (const SolveError&) {
    m.restore(saved);
    m.fraction = m.done_fraction;
    m.clock.reset();
    throw;
  } catch (const core::Error& e) {
    // The load stepping gave up: every step size tried inverted, diverged or did not converge.
    m.fraction = m.done_fraction;
    m.clock.reset();
    // The grid's advice names the last Newton solve's residual and det F, known only now.
    throw SolveError(m.grid && m.last_grid.min_J > 0 ? SolveFailure::kNotConverged : SolveFailure::kInverted,
                     m.grid ? std::string(e.what()) + m.gridFailureAdvice() : std::string(e.what()));
  }
  m.clock.reset();
  m.fraction = 1.0;
  report.output_scale = m.out_scale;
  double energy = 0, jmin = 0;
  {
    torch::NoGradGuard guard;
    Tensor l = m.loss(1.0, &energy, &jmin);
    if (!std::isfinite(l.item<double>()) || !(jmin > 0))
      throw SolveError(SolveFailure::kInverted, "DEM: the trained field is not admissible (NaN or det F <= 0)");
  }
  report.min_J = jmin;
  report.residual = std::numeric_limits<double>::quiet_NaN();
  if (m.grid) {
    // The answer is the grid Newton's: its energy and residual on its own quadrature.
    energy = m.last_grid.energy;
    report.residual = m.last_grid.residual;
    report.min_J = m.last_grid.min_J;
  }
  report.energy = energy;
  m.checkAnswer(report);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

void DemSolver::setControl(const SolveControl& control) { impl_->control = control; }

std::vector<Eigen::Vector3d> DemSolver::predict(const std::vector<Eigen::Vector3d>& points) const {
  return predict(points, impl_->fraction);
}

std::vector<Eigen::Vector3d> DemSolver::predict(const std::vector<Eigen::Vector3d>& points, double load_scale) const {
  const Impl& m = *impl_;
  m.checkLoadScale(load_scale);
  if (points.empty()) return {};
  torch::NoGradGuard guard;
  const Tensor x = toTensor(points, m.dtype);
  Tensor u;
  if (m.config.boundary == DemConfig::Boundary::kExact) {
    const DirichletLift lift = dirichletLift(m.scenario, points, m.length);
    const Tensor parts[4] = {toTensor(lift.g, m.dtype), Tensor(), toTensor(lift.D, m.dtype), Tensor()};
    u = m.displacement(x, parts, false, load_scale).first;
  } else {
    u = m.displacement(x, nullptr, false, load_scale).first;
  }
  u = u.to(torch::kFloat64).contiguous();
  std::vector<Eigen::Vector3d> out(points.size());
  const double* p = u.data_ptr<double>();
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return out;
}

core::ResultField DemSolver::result() const { return evaluate(impl_->cloud.positions, impl_->fraction); }

core::ResultField DemSolver::evaluate(const std::vector<Eigen::Vector3d>& points, double load_scale) const {
  const Impl& m = *impl_;
  m.checkLoadScale(load_scale);
  torch::NoGradGuard guard;
  core::ResultField r;
  r.positions = points;
  if (points.empty()) return r;
  const Tensor x = toTensor(points, m.dtype);
  const DirichletLift lift = dirichletLift(m.scenario, points, m.length);
  const Tensor parts[4] = {toTensor(lift.g, m.dtype), toTensor(lift.grad_g, m.dtype), toTensor(lift.D, m.dtype),
                           toTensor(lift.grad_D, m.dtype)};
  // One pass gives the displacement and its gradient.
  const auto [u, grad_u] = m.displacement(x, parts, true, load_scale);
  r.displacements = torch_support::toVectors(u);
  const Tensor gu = grad_u.to(torch::kFloat64).contiguous();
  const double* g = gu.data_ptr<double>();
  r.von_mises.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) F(a, b) += g[9 * i + 3 * a + b];
    r.von_mises[i] = F.determinant() > 0 ? vonMises(cauchyStress(F, m.material->stress(F)))
                                         : std::numeric_limits<double>::quiet_NaN();
  }
  return r;
}

const core::ParticleCloud& DemSolver::particles() const { return impl_->cloud; }

std::pair<double, double> DemSolver::loadRange() const {
  const Impl& m = *impl_;
  if (m.config.parametric) return {m.config.load_range_min, m.config.load_range_max};
  return {m.fraction, m.fraction};
}

void DemSolver::setProgressCallback(std::function<void(int iteration)> callback, int every) {
  impl_->progress = std::move(callback);
  impl_->progress_every = every;
}

DemState DemSolver::state() const {
  const Impl& m = *impl_;
  DemState st;
  st.config = m.config;
  st.scenario = m.scenario;
  st.cloud = m.cloud;
  st.output_scale = m.out_scale;
  st.energy_scale = m.energy_scale;
  st.fraction = m.fraction;
  st.rescaled = m.rescaled;
  for (std::size_t l = 0; l < m.weights.size(); ++l) {
    st.weights.push_back(toEigen(m.weights[l].detach()));
    st.biases.push_back(toEigen(m.biases[l].detach().unsqueeze(1)).col(0));
  }
  if (m.grid) st.grid_coefficients = toEigen(m.grid_coef.detach());
  return st;
}

DemSolver DemSolver::fromState(const DemState& state) {
  DemSolver solver(state.cloud, state.scenario, state.config);
  Impl& m = *solver.impl_;
  if (state.weights.size() != m.weights.size() || state.biases.size() != m.biases.size())
    throw core::Error("DEM state has " + std::to_string(state.weights.size()) + " layers; the config (depth " +
                      std::to_string(state.config.depth) + ") needs " + std::to_string(m.weights.size()));
  torch::NoGradGuard guard;
  for (std::size_t l = 0; l < m.weights.size(); ++l) {
    const Eigen::MatrixXd& W = state.weights[l];
    const Eigen::VectorXd& b = state.biases[l];
    if (W.rows() != m.weights[l].size(0) || W.cols() != m.weights[l].size(1) || b.size() != m.biases[l].size(0))
      throw core::Error("DEM state: layer " + std::to_string(l) + " is " + std::to_string(W.rows()) + " x " +
                        std::to_string(W.cols()) + ", the config needs " + std::to_string(m.weights[l].size(0)) +
                        " x " + std::to_string(m.weights[l].size(1)));
    if (!W.allFinite() || !b.allFinite()) throw core::Error("DEM state: layer " + std::to_string(l) + " holds NaN or inf");
    // Eigen is column-major: its transpose's buffer is the row-major (out x in) tensor.
    const Eigen::MatrixXd Wt = W.transpose();
    m.weights[l].copy_(torch::from_blob(const_cast<double*>(Wt.data()), {W.rows(), W.cols()}, torch::kFloat64));
    m.biases[l].copy_(torch::from_blob(const_cast<double*>(b.data()), {b.size()}, torch::kFloat64));
  }
  if (m.grid) {
    const Eigen::MatrixXd& C = state.grid_coefficients;
    if (C.rows() != m.grid->nodeCount() || C.cols() != 3 || !C.allFinite())
      throw core::Error("DEM state: the feature grid needs " + std::to_string(m.grid->nodeCount()) +
                        " x 3 finite coefficients, the state has " + std::to_string(C.rows()) + " x " +
                        std::to_string(C.cols()));
    m.setGridCoefficients(C);
  }
  if (!(state.output_scale > 0) || !(state.energy_scale > 0) || !std::isfinite(state.fraction))
    throw core::Error("DEM state: output and energy scales must be positive and the load fraction finite");
  m.out_scale = state.output_scale;
  m.energy_scale = state.energy_scale;
  m.fraction = state.fraction;
  m.rescaled = state.rescaled;
  return solver;
}

DemSolver::~DemSolver() = default;
DemSolver::DemSolver(DemSolver&&) noexcept = default;

}  // namespace demnerf::mechanics
