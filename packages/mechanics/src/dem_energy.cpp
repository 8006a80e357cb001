// The DEM's loss: the total potential energy of the particle-discretised body (strain energy
// minus the work of body forces and tractions), plus the paper's penalty in penalty mode; and the
// line search on the network's output amplitude.
#include <torch/torch.h>

#include <cmath>
#include <iostream>
#include <limits>

#include "amplitude_fit.hpp"
#include "dem_solver_impl.hpp"

namespace demnerf::mechanics {
namespace {

using torch::Tensor;

Tensor det3(const Tensor& F) {
  auto f = [&](int i, int j) { return F.select(1, i).select(1, j); };
  return f(0, 0) * (f(1, 1) * f(2, 2) - f(1, 2) * f(2, 1)) - f(0, 1) * (f(1, 0) * f(2, 2) - f(1, 2) * f(2, 0)) +
         f(0, 2) * (f(1, 0) * f(2, 1) - f(1, 1) * f(2, 0));
}

}  // namespace

// Stochastic quadrature in the band next to the fixtures: every Adam step moves each of those
// quadrature points within its cell (see DemConfig::jitter). The lift of the moved points is
// analytic and costs ~0.1 us per point. x and lift become the volume particles with the band moved;
// `mirrored` gives each band point two, at +-offset (the band's rows twice: +, then -).
void DemSolver::Impl::jitterBand(Tensor& x, Tensor (&lift)[4], bool mirrored) const {
  const long nb = n_band, nf = xv.size(0) - nb, rows = mirrored ? 2 * nb : nb;
  std::uniform_real_distribution<float> u01(-1.0f, 1.0f);
  std::vector<Eigen::Vector3d> offset(nb, Eigen::Vector3d::Zero());
  for (long i = 0; i < nb; ++i)
    if (band_jitter[i] > 0) offset[i] = band_jitter[i] * Eigen::Vector3d(u01(rng), u01(rng), u01(rng));
  Tensor xb = torch::empty({rows, 3}, torch::kFloat64);
  Tensor lb[4] = {torch::empty({rows, 3}, torch::kFloat64), torch::empty({rows, 3, 3}, torch::kFloat64),
                  torch::empty({rows, 3}, torch::kFloat64), torch::empty({rows, 3, 3}, torch::kFloat64)};
  double* px = xb.data_ptr<double>();
  double* pg = lb[0].data_ptr<double>();
  double* pgg = lb[1].data_ptr<double>();
  double* pd = lb[2].data_ptr<double>();
  double* pgd = lb[3].data_ptr<double>();
  const bool exact = config.boundary.kind == DemConfig::Boundary::kExact;
  Eigen::Vector3d g, D;
  Eigen::Matrix3d gg, gD;
  for (long i = 0; i < rows; ++i) {
    const Eigen::Vector3d p = band_points[i % nb] + (i < nb ? 1.0 : -1.0) * offset[i % nb];
    for (int c = 0; c < 3; ++c) px[3 * i + c] = p(c);
    if (!exact) continue;
    dirichletLiftAt(scenario, p, length, g, gg, D, gD, &held);
    for (int r = 0; r < 3; ++r) {
      pg[3 * i + r] = g(r);
      pd[3 * i + r] = D(r);
      for (int c = 0; c < 3; ++c) {
        pgg[9 * i + 3 * r + c] = gg(r, c);
        pgd[9 * i + 3 * r + c] = gD(r, c);
      }
    }
  }
  x = torch::cat({xv.narrow(0, 0, nf), xb.to(dtype)});
  if (exact)
    for (int k = 0; k < 4; ++k) lift[k] = torch::cat({lift_v[k].narrow(0, 0, nf), lb[k].to(dtype)});
}

// A mirrored draw (each band point at +-offset, half its weight at each): the offsets' first-order
// effect on every cell's energy cancels, so a draw's quadrature noise, which the sampled L-BFGS
// chases, is second order in the offset (Beam3D: the tip wandered +-2 % between one-point draws).
DemSolver::Impl::JitterDraw DemSolver::Impl::drawJitter() const {
  JitterDraw draw;
  jitterBand(draw.x, draw.lift, true);
  const long nf = xv.size(0) - n_band;
  const auto twice = [&](const Tensor& t) {
    const Tensor half = 0.5 * t.narrow(0, nf, n_band);
    return torch::cat({t.narrow(0, 0, nf), half, half});
  };
  draw.vol = twice(vol);
  draw.body = twice(body);
  return draw;
}

// Loss at load fraction `scale`: Pi / energy_scale (+ penalty). Sets the potential energy and min J.
// `draw` (a drawJitter()) replaces the volume particles; else `jitter` draws a fresh band.
Tensor DemSolver::Impl::loss(double scale, double* energy, double* min_J, bool jitter, const JitterDraw* draw) const {
  Tensor x = xv;
  Tensor lift_j[4];
  const Tensor* lift = lift_v;
  const GridSupport* support = grid ? &grid_v : nullptr;
  const Tensor* weights = &vol;
  const Tensor* body_forces = &body;
  if (draw) {
    x = draw->x;
    weights = &draw->vol;
    body_forces = &draw->body;
    if (config.boundary.kind == DemConfig::Boundary::kExact) lift = draw->lift;
    support = nullptr;
  } else if (jitter && n_band > 0) {
    jitterBand(x, lift_j);
    if (config.boundary.kind == DemConfig::Boundary::kExact) lift = lift_j;
    support = nullptr;  // the jittered points' grid support is computed from x
  }
  auto [uv, gu] = displacement(x, lift, true, scale, support);
  const Tensor F = gu + eye3;
  const Tensor J = det3(F);
  const Tensor psi = torch_support::neoHookeanEnergyDensity(J, (F * F).sum({1, 2}), *material, scenario.material.model);
  Tensor pi = (psi * *weights).sum() - scale * (*body_forces * uv).sum();
  if (xs.size(0) > 0) {
    auto [us, unused] = displacement(xs, lift_s, false, scale, grid ? &grid_s : nullptr);
    pi = pi - scale * (traction_area * us).sum();
  }
  Tensor total = pi / energy_scale;
  if (config.boundary.kind == DemConfig::Boundary::kPenalty && xc.size(0) > 0) {
    auto [uc, unused] = displacement(xc, nullptr, false, scale);
    const Tensor mse = ((uc - scale * fixed_value) * fixed_mask).pow(2).sum(1).mean();
    total = total + config.boundary.penalty_weight * mse / (out_scale * out_scale);
  }
  if (energy) *energy = pi.item<double>();
  if (min_J) *min_J = J.numel() ? J.min().item<double>() : 1.0;
  return total;
}

// Energy (J) at the particles' nominal positions with the output amplitude multiplied by alpha;
// NaN when a particle inverts.
double DemSolver::Impl::energyWithAmplitude(double scale, double alpha) {
  torch::NoGradGuard guard;
  const double saved = out_scale;
  out_scale = saved * alpha;
  double e = 0, jmin = 0;
  const Tensor l = loss(scale, &e, &jmin);
  out_scale = saved;
  const double total = l.item<double>() * energy_scale;
  return std::isfinite(total) && jmin > 0 ? total : std::numeric_limits<double>::quiet_NaN();
}

// The output amplitude refitted by a parabola in the energy (amplitude_fit.hpp); the energy scale
// follows, so the loss stays O(1).
void DemSolver::Impl::rescaleOutput(double scale) {
  const std::optional<double> alpha = fitAmplitude([&](double a) { return energyWithAmplitude(scale, a); });
  if (!alpha) return;
  out_scale *= *alpha;
  energy_scale *= *alpha * *alpha;
  if (config.verbose) std::cerr << "dem: output amplitude x" << *alpha << " -> " << out_scale << " m\n";
}

}  // namespace demnerf::mechanics
