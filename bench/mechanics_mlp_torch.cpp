#include "mechanics_mlp_torch.hpp"

#include <cmath>
#include <cstdio>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_reference.hpp"

namespace demnerf::bench::mlp {

namespace geo = demnerf::geometry;
namespace bench = demnerf::bench;

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

void demFromFit(const Setup& su, const Net& net, dm::DemState st, double s, double cpu0) {
  net.into(st);
  st.energy_scale *= (s / st.output_scale) * (s / st.output_scale);
  st.output_scale = s;
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

}  // namespace demnerf::bench::mlp
