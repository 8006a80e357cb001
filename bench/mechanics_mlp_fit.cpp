// What the paper's DEM network can represent, apart from how it is trained: the MLP of
// `--method mlp` (paperDemConfig(), u = g + D s z(X) with the exact-boundary lift) fitted by least
// squares to the matrix's reference FEM field at a cloud's particles, then handed to the DEM as its
// starting state. The fit's rel. L2 is the network's capacity on this problem; the DEM's check on
// the fitted field (its Newton correction and energy) and a further DEM training from it show
// whether the energy the DEM minimises has its minimum where the FEM's is.
//
// Usage: mechanics_mlp_fit key=value ...
//   scenario=tbar_twist  sampler=grid|poisson|random  div=10  seed=1  ref=DIR (required: a
//   mechanics_matrix out= dir holding these particles)  config=FILE (over paperDemConfig())
//   target=fem (values at the particles) | grid (values and gradients of the default DEM's answer,
//   which is 0.7 % from the FEM, on the MLP's cell quadrature) | strain (values and Green strain)
//   fit=3000 (L-BFGS iterations of the fit)  load=FILE (start from a saved fit; fit=0 default then)
//   save=FILE (the fit as a DEM model)  dem=0 (DEM L-BFGS iterations from the fit)  every=250
//   time_limit=600  fused=1  cell=0.01 (the MLP's quadrature cell)  spacing=0.006 (its margin / 0.5)
//   regions=0.03,0.24 (z bounds of the T-bar's clamp layer, leg and bar in the strain figures)
//   probe=1: only the quadrature's volume and leg moment (T-bar) and the loads' resultants
#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/held_face.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_reference.hpp"
#include "mechanics_mlp_torch.hpp"

namespace dm = demnerf::mechanics;
namespace bench = demnerf::bench;
using namespace demnerf::bench::mlp;

namespace {

// probe=1: the quadrature's volume and the leg's polar moment (T-bar), the loads' resultants.
void printProbe(const Setup& su, const Quadrature& qu) {
  double v = 0, leg = 0;
  for (std::size_t i = 0; i < qu.q.points.size(); ++i) {
    const Vector3d& p = qu.q.points[i];
    v += qu.q.weights[i];
    if (p.z() > 0.03 && p.z() < 0.21) leg += qu.q.weights[i] * (p.x() * p.x() + p.y() * p.y());
  }
  const double exact_leg = 0.18 * std::pow(0.06, 4) / 6;
  std::printf("quadrature: %zu points, volume %.6g (T-bar 0.001944), leg polar moment over z 0.03..0.21 %.5g "
              "(T-bar %.5g: %+.2f %%)\n", qu.q.points.size(), v, leg, exact_leg, 100 * (leg / exact_leg - 1));
  const std::vector<Vector3d> t = dm::particleTractions(su.scenario, su.cloud);
  Vector3d f = Vector3d::Zero(), m = Vector3d::Zero();
  for (std::size_t i = 0; i < su.cloud.size(); ++i)
    if (su.cloud.areas[i] > 0) f += su.cloud.areas[i] * t[i], m += su.cloud.positions[i].cross(su.cloud.areas[i] * t[i]);
  std::printf("loads on the particles: F (%.4g %.4g %.4g), M (%.5g %.5g %.5g)\n", f(0), f(1), f(2), m(0), m(1), m(2));
}

// The Green strain's error of a field against a target's, over the whole and in three z bands.
void printStrainErrors(const Setup& su, const Quadrature& qu, const Tensor& du, const Tensor& dU) {
  const Tensor E = green(dU), err = qu.w * (green(du) - E).pow(2).sum({1, 2}), ref2 = qu.w * E.pow(2).sum({1, 2});
  const std::string bounds = text(su.a, "regions", "0.03,0.24");
  const double z1 = std::stod(bounds.substr(0, bounds.find(','))), z2 = std::stod(bounds.substr(bounds.find(',') + 1));
  const Tensor z = qu.x.select(1, 2);
  const std::pair<std::string, Tensor> bands[3] = {{"z < " + std::to_string(z1), z < z1},
                                                   {"between", (z >= z1) & (z <= z2)},
                                                   {"z > " + std::to_string(z2), z > z2}};
  for (const auto& [band, mask] : bands)
    std::printf("  strain error %s: %.2f %% of the whole's strain norm, %.2f %% of its own\n", band.c_str(),
                100 * std::sqrt(((err * mask).sum() / ref2.sum()).item<double>()),
                100 * std::sqrt(((err * mask).sum() / (ref2 * mask).sum()).item<double>()));
  std::printf("FIT strain error %.3f %%, gradient error %.3f %% (rel. L2 on the quadrature)\n",
              100 * std::sqrt((err.sum() / ref2.sum()).item<double>()),
              100 * std::sqrt(((qu.w * (du - dU).pow(2).sum({1, 2})).sum() / (qu.w * dU.pow(2).sum({1, 2})).sum())
                                  .item<double>()));
}

// The default DEM's answer (values and central-difference gradients) on the quadrature.
std::pair<Tensor, Tensor> gridAnswer(const Setup& su, const Quadrature& qu) {
  dm::DemSolver grid(su.cloud, su.scenario, dm::solverDefaults("grid", "").dem);
  grid.solve();
  std::printf("default DEM: rel L2 %.3f %% from the FEM\n", 100 * relL2(rows(grid.predict(su.cloud.positions)), su.ref));
  const double h = 1e-4;
  Tensor dU = torch::zeros({qu.x.size(0), 3, 3}, torch::kFloat64);
  for (int k = 0; k < 3; ++k) {
    std::vector<Vector3d> plus = qu.q.points, minus = qu.q.points;
    for (std::size_t i = 0; i < plus.size(); ++i) plus[i](k) += h, minus[i](k) -= h;
    dU.select(2, k).copy_((rows(grid.predict(plus)) - rows(grid.predict(minus))) / (2 * h));
  }
  printEnergy("the default DEM's field", su, qu, dU, rows(grid.predict(su.cloud.positions)));
  return {rows(grid.predict(qu.q.points)), dU};
}

// L-BFGS on the fit's loss: values at the particles (target=fem), or values and gradients /
// Green strains of the default DEM's answer on the quadrature (grid / strain).
void fit(Net& net, const Setup& su, const Quadrature& qu, int iterations) {
  torch::optim::LBFGS lbfgs(net.parameters(), torch::optim::LBFGSOptions(1.0).max_iter(iterations).history_size(50)
                                                  .line_search_fn("strong_wolfe").tolerance_grad(1e-14)
                                                  .tolerance_change(1e-16));
  const std::string target = text(su.a, "target", "fem");
  const double s = su.s;
  if (target == "fem") {
    lbfgs.step([&] {
      lbfgs.zero_grad();
      Tensor l = ((su.g + su.D * s * net.z(su.x) - su.ref) / s).pow(2).mean();
      l.backward();
      return l;
    });
    return;
  }
  const auto [U, dU] = gridAnswer(su, qu);
  const Tensor E = green(dU);
  const double a2 = 0.03 * 0.03, e2 = 0.01 * 0.01;  // the leg's half width; a strain scale
  lbfgs.step([&] {
    lbfgs.zero_grad();
    const Tensor u = qu.g + qu.D * s * net.z(qu.x), du = qu.du(net, s);
    Tensor l = target == "strain" ? (qu.w * ((u - U).pow(2).sum(1) / (s * s) + (green(du) - E).pow(2).sum({1, 2}) / e2)).sum()
                                  : (qu.w * ((u - U).pow(2).sum(1) + a2 * (du - dU).pow(2).sum({1, 2}))).sum() / (s * s);
    l.backward();
    return l;
  });
  torch::NoGradGuard guard;
  printStrainErrors(su, qu, qu.du(net, s), dU);
}

}  // namespace

int main(int argc, char** argv) {
  dm::keepLargeAllocationsInHeap();
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Setup su = setUp(bench::keyValueArguments(argc, argv));
  const Quadrature qu = mlpQuadrature(su);
  if (text(su.a, "probe", "0") != "0") return printProbe(su, qu), 0;
  dm::DemConfig config = dm::solverDefaults("mlp", text(su.a, "config", "")).dem;
  config.verbose = true;
  const dm::DemState st = dm::DemSolver(su.cloud, su.scenario, config).state();
  Net net;
  net.center = rows({0.5 * (su.lo + su.hi)});
  net.inv_half = rows({(0.5 * (su.hi - su.lo)).cwiseInverse()});
  net.set(st);
  const std::string load = text(su.a, "load", "");
  if (!load.empty()) net.set(dm::loadDemModel(load).state());
  std::printf("%s %s 1/%s: %zu particles, network %dx%d, u = g + D s z (s = %.4g m), target %s\n", su.name.c_str(),
              text(su.a, "sampler", "grid").c_str(), text(su.a, "div", "10").c_str(), su.cloud.size(),
              config.network.width, config.network.depth, su.s, text(su.a, "target", "fem").c_str());
  const double cpu0 = bench::processCpuSeconds();
  const int iterations = std::stoi(text(su.a, "fit", load.empty() ? "3000" : "0"));
  if (iterations > 0) fit(net, su, qu, iterations);
  {
    torch::NoGradGuard guard;
    const Tensor u = su.g + su.D * su.s * net.z(su.x);
    std::printf("FIT: rel L2 %.3f %%, max err %.3f %% of max|u| (%.1f CPU-s)\n", 100 * relL2(u, su.ref),
                100 * ((u - su.ref).norm(2, 1).max() / su.ref.norm(2, 1).max()).item<double>(),
                bench::processCpuSeconds() - cpu0);
    printEnergy("the fit", su, qu, qu.du(net, su.s), u);
  }
  demFromFit(su, net, st, su.s, cpu0);
  return 0;
}
