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

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
namespace geo = demnerf::geometry;
namespace bench = demnerf::bench;
using Eigen::Vector3d;
using torch::Tensor;

namespace {

using Arguments = std::map<std::string, std::string>;

std::string text(const Arguments& a, const char* key, const std::string& fallback) {
  const auto it = a.find(key);
  return it != a.end() ? it->second : fallback;
}

Tensor rows(const std::vector<Vector3d>& v) {
  Tensor t = torch::empty({static_cast<long>(v.size()), 3}, torch::kFloat64);
  auto acc = t.accessor<double, 2>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) acc[i][k] = v[i](k);
  return t;
}

Tensor matrices(const std::vector<Eigen::Matrix3d>& v) {
  Tensor t = torch::empty({static_cast<long>(v.size()), 3, 3}, torch::kFloat64);
  auto acc = t.accessor<double, 3>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) acc[i][r][c] = v[i](r, c);
  return t;
}

double relL2(const Tensor& u, const Tensor& ref) { return ((u - ref).norm() / ref.norm()).item<double>(); }

Tensor green(const Tensor& du) {
  const Tensor F = torch::eye(3, torch::kFloat64).unsqueeze(0) + du;
  return 0.5 * (torch::matmul(F.transpose(1, 2), F) - torch::eye(3, torch::kFloat64).unsqueeze(0));
}

// The DEM network in double: z = W_L tanh(...tanh(W_0 (X - c) / h + b_0)...) + b_L.
struct Net {
  std::vector<Tensor> W, b;
  Tensor center, inv_half;
  Tensor z(const Tensor& x) const {
    Tensor h = (x - center) * inv_half;
    for (std::size_t l = 0; l + 1 < W.size(); ++l) h = torch::tanh(torch::addmm(b[l], h, W[l].t()));
    return torch::addmm(b.back(), h, W.back().t());
  }
  // z and its X-gradient [n, i, k] = dz_i / dX_k, forward mode.
  std::pair<Tensor, Tensor> withGradient(const Tensor& x) const {
    Tensor h = (x - center) * inv_half;
    Tensor dh = torch::diag(inv_half.squeeze(0)).unsqueeze(0).expand({x.size(0), 3, 3});  // [n, k, in]
    for (std::size_t l = 0; l + 1 < W.size(); ++l) {
      h = torch::tanh(torch::addmm(b[l], h, W[l].t()));
      dh = (1 - h * h).unsqueeze(1) * torch::matmul(dh, W[l].t());
    }
    return {torch::addmm(b.back(), h, W.back().t()), torch::matmul(dh, W.back().t()).transpose(1, 2)};
  }
  std::vector<Tensor> parameters() const {
    std::vector<Tensor> p;
    for (std::size_t l = 0; l < W.size(); ++l) p.push_back(W[l]), p.push_back(b[l]);
    return p;
  }
  void set(const dm::DemState& st) {
    torch::NoGradGuard guard;
    for (std::size_t l = 0; l < st.weights.size(); ++l) {
      const Eigen::MatrixXd Wt = st.weights[l].transpose();  // column-major: its buffer is W row-major
      const Tensor w = torch::from_blob(const_cast<double*>(Wt.data()), {st.weights[l].rows(), st.weights[l].cols()},
                                        torch::kFloat64);
      const Tensor bias = torch::from_blob(const_cast<double*>(st.biases[l].data()), {st.biases[l].size()}, torch::kFloat64);
      if (W.size() <= l) W.push_back(w.clone().requires_grad_(true)), b.push_back(bias.clone().requires_grad_(true));
      else W[l].copy_(w), b[l].copy_(bias);
    }
  }
  void into(dm::DemState& st) const {
    for (std::size_t l = 0; l < W.size(); ++l) {
      const Tensor w = W[l].detach().contiguous(), bias = b[l].detach().contiguous();
      st.weights[l] = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          w.data_ptr<double>(), w.size(0), w.size(1));
      st.biases[l] = Eigen::Map<const Eigen::VectorXd>(bias.data_ptr<double>(), bias.size(0));
    }
  }
};

// One matrix cloud with its reference and the solver's view of it (box, lift at the particles).
struct Setup {
  Arguments a;
  std::string name;
  core::Scenario scenario;
  core::ParticleCloud cloud;
  Tensor ref, x, g, D;
  Vector3d lo, hi;
  double length = 1.0, s = 1.0;  // s: the output scale of the fit, max |u_ref|
  std::vector<dm::HeldFace> held;
};

Setup setUp(const Arguments& a) {
  Setup su;
  su.a = a;
  su.name = text(a, "scenario", "tbar_twist");
  bench::MatrixCase mc;
  for (const bench::MatrixCase& c : bench::matrixCases())
    if (c.name == su.name) mc = c;
  if (mc.name.empty()) throw core::Error("unknown scenario '" + su.name + "'");
  su.scenario = core::loadScenario(std::string(DEMNERF_ROOT) + "/config/scenarios/" + su.name + ".yaml");
  geo::SamplerConfig sampler;
  sampler.method = geo::parseSamplingMethod(text(a, "sampler", "grid"));
  sampler.spacing = mc.smallest / std::stoi(text(a, "div", "10"));
  sampler.seed = static_cast<std::uint64_t>(std::stoi(text(a, "seed", "1")));
  su.cloud = geo::sampleParticles(mc.surface(), sampler);
  const core::ResultField cached = core::readResult(text(a, "ref", ".") + "/reference_" + su.name + "_exact_fine.ply");
  const std::optional<core::ResultField> at = bench::cachedAt(cached, su.cloud);
  if (!at) throw core::Error("the reference does not hold these particles");
  su.ref = rows(at->displacements);
  su.s = su.ref.abs().max().item<double>();
  su.lo = su.hi = su.cloud.positions[0];
  for (const Vector3d& p : su.cloud.positions) su.lo = su.lo.cwiseMin(p), su.hi = su.hi.cwiseMax(p);
  su.length = (su.hi - su.lo).maxCoeff();
  su.held = dm::heldFaces(su.scenario, su.cloud);
  const dm::DirichletLift lift = dm::dirichletLift(su.scenario, su.cloud.positions, su.length, &su.held);
  su.x = rows(su.cloud.positions);
  su.g = rows(lift.g);
  su.D = rows(lift.D);
  return su;
}

// The MLP's cell quadrature as cellDraw() builds it (2 Gauss points per axis, cut cells
// moment-fitted whole), with the lift there.
struct Quadrature {
  dm::CellQuadrature q;
  Tensor x, w, g, D, grad_g, grad_D;  // w normalised to sum 1
  Tensor du(const Net& net, double s) const {
    const auto [z, dz] = net.withGradient(x);
    return grad_g + grad_D * (s * z).unsqueeze(2) + D.unsqueeze(2) * s * dz;
  }
};

Quadrature mlpQuadrature(const Setup& su) {
  Quadrature out;
  const Vector3d margin = Vector3d::Constant(0.5 * std::stod(text(su.a, "spacing", "0.006")));
  const dm::BsplineGrid cells(su.lo - margin, su.hi + margin, std::stod(text(su.a, "cell", "0.01")), 1);
  out.q = dm::cellQuadrature(su.cloud, cells, dm::CellQuadratureConfig{2, 0});
  const dm::DirichletLift lift = dm::dirichletLift(su.scenario, out.q.points, su.length, &su.held);
  out.x = rows(out.q.points);
  out.w = torch::tensor(out.q.weights, torch::kFloat64);
  out.w = out.w / out.w.sum();
  out.g = rows(lift.g);
  out.D = rows(lift.D);
  out.grad_g = matrices(lift.grad_g);
  out.grad_D = matrices(lift.grad_D);
  return out;
}

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

// Strain energy on the quadrature (compressible Neo-Hookean, as the DEM's kernel) and the work
// of the particle loads on u at the particles: the DEM's potential, computed independently.
void printEnergy(const char* what, const Setup& su, const Quadrature& qu, const Tensor& du, const Tensor& u_particles) {
  const Tensor F = torch::eye(3, torch::kFloat64).unsqueeze(0) + du;
  const Tensor lnJ = torch::log(torch::det(F));
  const double mu = su.scenario.material.mu(), lambda = su.scenario.material.lambda();
  const Tensor psi = 0.5 * mu * (F.pow(2).sum({1, 2}) - 3) - mu * lnJ + 0.5 * lambda * lnJ * lnJ;
  const Tensor weights = torch::tensor(qu.q.weights, torch::kFloat64);
  const double U = (weights * psi).sum().item<double>();
  const double bar = (weights * psi * (qu.x.select(1, 2) > 0.24)).sum().item<double>();
  const std::vector<Vector3d> t = dm::particleTractions(su.scenario, su.cloud);
  double W = 0;
  auto acc = u_particles.accessor<double, 2>();
  for (std::size_t i = 0; i < su.cloud.size(); ++i)
    if (su.cloud.areas[i] > 0)
      for (int k = 0; k < 3; ++k) W += su.cloud.areas[i] * t[i](k) * acc[i][k];
  std::printf("ENERGY of %s: strain %.6g J (z > 0.24: %.6g), work %.6g J, potential %.6g J\n", what, U, bar, W, U - W);
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

// The fitted field as the DEM's state: its check, and the DEM's training from it.
void demFromFit(const Setup& su, const Net& net, dm::DemState st, double cpu0) {
  net.into(st);
  st.energy_scale *= (su.s / st.output_scale) * (su.s / st.output_scale);
  st.output_scale = su.s;
  st.fraction = 1.0;
  st.rescaled = true;
  if (!text(su.a, "save", "").empty()) dm::saveDemModel(dm::DemSolver::fromState(st), text(su.a, "save", ""));
  st.config.lbfgs.iterations = std::stoi(text(su.a, "dem", "0"));
  st.config.network.fused = text(su.a, "fused", "1") != "0";
  dm::DemSolver dem = dm::DemSolver::fromState(st);
  dm::SolveControl control;
  control.time_limit = std::stod(text(su.a, "time_limit", "600"));
  double energy = std::nan("");
  control.progress_interval = 0.0;
  control.progress = [&](const dm::SolveProgress& p) { energy = p.energy; };
  dem.setControl(control);
  const auto reading = [&](const char* what, int it) {
    std::printf("%s it %5d  cpu %7.2f s  rel L2 %.3f %%  energy %.6g J\n", what, it, bench::processCpuSeconds() - cpu0,
                100 * relL2(rows(dem.predict(su.cloud.positions)), su.ref), energy);
  };
  dem.setProgressCallback([&](int it) { reading("DEM", it); }, std::stoi(text(su.a, "every", "250")));
  std::string verdict = "passes the check";
  dm::DemReport report;
  try {
    report = dem.solve();
  } catch (const std::exception& e) {
    verdict = std::string("REFUSED: ") + e.what();
  }
  reading("DEM end", report.iterations);
  std::printf("RESULT DEM energy %.6g J: %s\n", report.energy, verdict.c_str());
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
  demFromFit(su, net, st, cpu0);
  return 0;
}
