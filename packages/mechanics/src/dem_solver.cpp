// The public DemSolver: checks, the particle sets of a scenario, the load stepping of a solve and
// the answers (predict, evaluate). Its parts: dem_solver_impl.hpp.
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "adaptive_load_steps.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/particle_quadrature.hpp"
#include "demnerf/mechanics/surface_loads.hpp"
#include "dem_config_check.hpp"
#include "dem_solver_impl.hpp"

namespace demnerf::mechanics {

using torch::Tensor;
using torch_support::toTensor;

namespace {
// The default DEM's load lattice (surface_loads.hpp): this many steps per grid cell make the load
// smooth at the cell's scale and clip a region's edge to an eighth of a cell.
constexpr double kLoadStepsPerCell = 8.0;
}  // namespace

DemSolver::DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config)
    : DemSolver(std::move(cloud), scenario, std::move(config), nullptr) {}

DemSolver::DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config,
                     const SolveControl& control)
    : DemSolver(std::move(cloud), scenario, std::move(config), &control) {}

DemSolver::DemSolver(core::ParticleCloud cloud, const core::Scenario& scenario, DemConfig config,
                     const SolveControl* control)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (control) {
    // The set-up counts against the solve's budget (issue 13: a 60 s limit ran 118 s on the fox,
    // 40 s of it the cell quadrature before the solve's clock started).
    m.control = *control;
    m.setup_start = std::chrono::steady_clock::now();
    m.clock = std::make_unique<SolveClock>(*control, "dem", *m.setup_start);
  }
  validateProblem(scenario, cloud);
  const ResolvedDemConfig resolved = resolvedDemConfig(config, cloud);
  config = resolved.config;
  const double spacing = resolved.spacing;
  m.coarse_grid = resolved.coarse_grid;
  m.config = config;
  m.dtype = config.network.double_precision ? torch::kFloat64 : torch::kFloat32;
  m.cloud = std::move(cloud);
  torch::manual_seed(config.network.seed);
  const torch_support::BodyBox box = torch_support::bodyBox(m.cloud);
  m.length = box.length;
  m.load_input_scale = std::max(std::abs(config.parametric.load_range_min), std::abs(config.parametric.load_range_max));
  m.eye3 = torch::eye(3, torch::TensorOptions().dtype(m.dtype)).unsqueeze(0);
  m.rng.seed(static_cast<unsigned>(config.network.seed));
  const Eigen::Vector3d input_half =
      config.network.thickness_inputs ? Eigen::Vector3d::Constant(box.half.minCoeff()) : box.half;
  m.net = DisplacementMlp(config.parametric.enabled ? 1 : 0, config.network.width, config.network.depth, config.network.activation, box.center,
                          input_half, m.dtype, config.network.first_layer_scale);
  if (config.grid.cell > 0) {
    // The cell quadrature gets half a spacing of margin: a lattice cloud whose outer particles
    // carry whole cells of volume describes a body that far beyond its particles
    // (cell_quadrature.hpp moves the surface out). The particle quadrature stays on the particles:
    // nodes seen only at the edge of their support would be near-singular.
    const double pad = config.grid.quadrature == DemConfig::GridQuadrature::kCells ? 0.5 * spacing : 0.0;
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(pad);
    m.grid = std::make_unique<BsplineGrid>(box.center - box.half - margin, box.center + box.half + margin,
                                           config.grid.cell, config.grid.degree);
    if (m.grid->nodeCount() > 4000000)
      throw core::Error("DEM feature grid of " + std::to_string(m.grid->nodeCount()) + " nodes: grid.cell " +
                        std::to_string(config.grid.cell) + " m is far too fine for a body of " +
                        std::to_string(m.length) + " m; use a cell of a few particle spacings");
    m.grid_coef = torch::zeros({m.grid->nodeCount(), 3}, torch::TensorOptions().dtype(m.dtype)).requires_grad_(true);
    m.makeCoarseLevels(box.center - box.half - margin, box.center + box.half + margin);
  }
  setScenario(scenario);
  m.clock.reset();
}

// Fixed-first order: the interior particles near a fixture go last, as the jittered band (see
// DemConfig::jitter). `volume_particles` is reordered so.
void DemSolver::Impl::orderBandLast(std::vector<long>& volume_particles) {
  std::vector<long> fixed_part, band_part;
  std::vector<double> half_cell(cloud.size(), 0.0);
  for (long i : volume_particles) {
    const bool interior = cloud.volumes[i] > 0 && !cloud.isSurface(i);
    double near = std::numeric_limits<double>::infinity();
    if (interior) {
      half_cell[i] = 0.5 * std::cbrt(cloud.volumes[i]);
      for (const core::Fixture& f : scenario.fixtures) near = std::min(near, regionDistance(f.region, cloud.positions[i]));
    }
    (interior && config.adam.jitter && near < config.adam.jitter_band * 2 * half_cell[i] ? band_part : fixed_part).push_back(i);
  }
  volume_particles = fixed_part;
  volume_particles.insert(volume_particles.end(), band_part.begin(), band_part.end());
  n_band = static_cast<long>(band_part.size());
  band_points.clear();
  band_jitter.clear();
  for (long i : band_part) {
    band_points.push_back(cloud.positions[i]);
    band_jitter.push_back(half_cell[i]);
  }
}

// The particle subsets and their tensors for the current scenario: volume particles (band last),
// traction particles, fixed particles, the lift at each, and the grid supports and quadrature.
DemSolver::Impl::LoadSizes DemSolver::Impl::setParticleSets() {
  const auto traction = particleTractions(scenario, cloud);
  const Dirichlet fixed = resolveHeldParticles(scenario, cloud, held);
  const DirichletLift lift = liftAt(cloud.positions);
  // Jittered cells are sampled over their whole volume, which already covers the strip between the
  // outer particle layer and the surface: they keep their own volume (moving a share to surface
  // points would under-weight that strip and reopen a cheaper-than-physical surface layer; measured
  // on the uniaxial cube: energy 2 % below the exact minimum). Fixed quadrature needs the shares.
  const std::vector<double> weight = config.adam.jitter ? cloud.volumes : energyWeights(cloud);
  std::vector<long> vi, si;
  double volume = 0.0, max_t = 0.0, max_g = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (weight[i] > 0) vi.push_back(static_cast<long>(i));
    if (cloud.areas[i] > 0 && traction[i].squaredNorm() > 0) si.push_back(static_cast<long>(i));
    volume += cloud.volumes[i];
    max_t = std::max(max_t, traction[i].norm());
  }
  if (vi.empty()) throw core::Error("the particle cloud has no particle with volume > 0");
  orderBandLast(vi);
  for (const auto& v : fixed.value) max_g = std::max(max_g, v.norm());
  const auto pick = [&](const std::vector<long>& idx, const auto& all) {
    using T = typename std::decay_t<decltype(all)>::value_type;
    std::vector<T> out;
    for (long i : idx) out.push_back(all[i]);
    return toTensor(out, dtype);
  };
  std::vector<double> vols;
  std::vector<Eigen::Vector3d> body_forces;
  for (long i : vi) {
    vols.push_back(weight[i]);
    body_forces.push_back(weight[i] * scenario.body_force);
  }
  xv = pick(vi, cloud.positions);
  vol = toTensor(vols, dtype);
  body = toTensor(body_forces, dtype);
  lift_v[0] = pick(vi, lift.g);
  lift_v[1] = pick(vi, lift.grad_g);
  lift_v[2] = pick(vi, lift.D);
  lift_v[3] = pick(vi, lift.grad_D);
  // The default DEM, and the MLP alone unless surface_loads is off: the loads spread evenly over the
  // surface the particles describe, at a fraction of the grid's cell (surface_loads.hpp), not as
  // point forces on the sampler's surface particles, which the grid resolves. The MLP's grid is its
  // equilibrium check's basis: with point loads that basis must stay two spacings coarse, and the
  // NeRF T-bar's under-twisted 1/6 answers passed in it (docs/dem_feature_grid.md).
  const bool cells = grid && config.grid.quadrature == DemConfig::GridQuadrature::kCells;
  if (cells || (!grid && config.surface_loads)) {
    setupTick("loads spread over the surface");
    const double cell = grid ? config.grid.cell : checkCell().grid;
    const SurfaceLoads loads = surfaceLoads(scenario, cloud, cell / kLoadStepsPerCell);
    setLoadPoints(loads.points, loads.forces);
  } else {
    std::vector<Eigen::Vector3d> points, forces;
    for (long i : si) {
      points.push_back(cloud.positions[i]);
      forces.push_back(cloud.areas[i] * traction[i]);
    }
    setLoadPoints(points, forces);
  }
  if (grid) {
    grid_v = gridSupport(xv);
    buildGridQuadrature();
    setupTick("quadrature done");
  }
  std::vector<long> ci(fixed.index.begin(), fixed.index.end());
  std::vector<Eigen::Vector3d> mask;
  for (const auto& k : fixed.mask) mask.push_back(k.cast<double>());
  xc = pick(ci, cloud.positions);
  fixed_value = toTensor(fixed.value, dtype);
  fixed_mask = toTensor(mask, dtype);
  return {volume, max_t, max_g};
}

// The loads as forces at points (surface particles, or surfaceLoads()'s points), with the lift
// and the grid's support there.
void DemSolver::Impl::setLoadPoints(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<Eigen::Vector3d>& forces) {
  xs = points.empty() ? torch::zeros({0, 3}, torch::TensorOptions().dtype(dtype)) : toTensor(points, dtype);
  traction_area = forces.empty() ? torch::zeros({0, 3}, torch::TensorOptions().dtype(dtype)) : toTensor(forces, dtype);
  if (points.empty()) return;
  const DirichletLift lift = liftAt(points);
  lift_s[0] = toTensor(lift.g, dtype);
  lift_s[1] = toTensor(lift.grad_g, dtype);
  lift_s[2] = toTensor(lift.D, dtype);
  lift_s[3] = toTensor(lift.grad_D, dtype);
  if (grid) grid_s = gridSupport(xs);
}

void DemSolver::setScenario(const core::Scenario& scenario) {
  Impl& m = *impl_;
  validateProblem(scenario, m.cloud);
  m.scenario = scenario;
  m.held = heldFaces(scenario, m.cloud);
  m.material = makeMaterial(scenario.material);
  const Impl::LoadSizes sizes = m.setParticleSets();
  // Scales: the network outputs O(1) for the expected displacement, and the loss is O(1) at the
  // expected strain, so optimiser tolerances mean the same thing for every body and load.
  // A trained network keeps its fitted amplitude (a better guess than the a-priori one); the next
  // solve refits it.
  const double E = scenario.material.youngs_modulus;
  if (!m.rescaled) {
    m.out_scale = std::max({sizes.max_prescribed,
                            m.length * (sizes.max_traction + scenario.body_force.norm() * m.length) / E, 1e-6 * m.length});
    const double strain = m.out_scale / m.length;
    m.energy_scale = m.material->mu() * sizes.volume * strain * strain;
  }
  m.rescaled = false;
  m.fraction = 0.0;
}

namespace {

SolveError parametricDivergence(const DemConfig& config) {
  return SolveError(SolveFailure::kInverted, "DEM (parametric): training over load fractions [" +
                                                 std::to_string(config.parametric.load_range_min) + ", " +
                                                 std::to_string(config.parametric.load_range_max) +
                                                 "] inverted particles (det F <= 0) or diverged (NaN); narrow the "
                                                 "range or lower the learning rate");
}

}  // namespace

DemReport DemSolver::solve() {
  Impl& m = *impl_;
  torch_support::setSolverThreads(m.config.threads, m.cloud.size());
  const auto start = std::chrono::steady_clock::now();
  DemReport report;
  m.clock = std::make_unique<SolveClock>(m.control, "dem", m.setup_start.value_or(start));
  m.setup_start.reset();
  m.done_fraction = 0.0;
  m.last_grid = GridNewtonOutcome{};
  m.adam_seconds = 0.0;
  m.adam_steps = 0;
  std::vector<Tensor> saved = m.snapshot();
  try {
    if (m.config.parametric.enabled) {
      if (!m.trainParametric(report.iterations)) {
        m.restore(saved);
        throw parametricDivergence(m.config);
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
  } catch (const SolveError& e) {
    m.restore(saved);
    m.fraction = m.done_fraction;
    m.clock.reset();
    if (m.grid || e.failure() != SolveFailure::kTimeLimit) throw;
    throw SolveError(e.failure(), std::string(e.what()) + ". " + m.adamPaceAdvice());
  } catch (const core::Error& e) {
    // The load stepping gave up: every step size tried inverted, diverged or did not converge.
    m.fraction = m.done_fraction;
    m.clock.reset();
    // The grid's advice names the last Newton solve's residual and det F, known only now.
    throw SolveError(m.grid && m.last_grid.min_J > 0 ? SolveFailure::kNotConverged : SolveFailure::kInverted,
                     m.grid ? std::string(e.what()) + m.gridFailureAdvice() : std::string(e.what()));
  }
  m.continueRefusedAnswer(report.iterations);  // MLP alone (a no-op otherwise), on the solve's clock: within its limit
  m.clock.reset();
  m.fraction = 1.0;
  report.output_scale = m.out_scale;
  double energy = 0, jmin = 0;
  {
    torch::NoGradGuard guard;
    Tensor l = m.loss(1.0, &energy, &jmin);
    if (!std::isfinite(l.item<double>()) || !(jmin > 0))
      throw SolveError(SolveFailure::kInverted, "DEM: the trained field is not admissible (NaN or det F <= 0)");
    // Trained on the cell quadrature: its energy is the one minimised (a Poisson cloud's particle
    // volumes would report Beam3D's -3.15 J as -3.79 J).
    if (!m.grid && m.config.lbfgs.cell_spacings > 0 && m.cell_draw.x.defined()) m.loss(1.0, &energy, nullptr, false, &m.cell_draw);
  }
  report.min_J = jmin;
  report.residual = std::numeric_limits<double>::quiet_NaN();
  if (m.grid) {
    // The answer is the grid Newton's: its energy and residual on its own quadrature.
    energy = m.last_grid.energy;
    report.residual = m.last_grid.residual;
    report.held_unknowns = m.last_grid.held;
    report.held_residual = m.last_grid.held_residual;
    report.min_J = m.last_grid.min_J;
    if (m.config.verbose) m.mlpEquilibrium(1.0);  // the MLP's check on this answer, for comparison only
  }
  report.energy = energy;
  report.coarse_grid = m.coarse_grid;
  if (!m.grid) m.verifyMlpAnswer(report);  // no Newton says the MLP converged: its own check
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
  if (m.config.boundary.kind == DemConfig::Boundary::kExact) {
    const DirichletLift lift = m.liftAt(points);
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
  const DirichletLift lift = m.liftAt(points);
  const Tensor parts[4] = {toTensor(lift.g, m.dtype), toTensor(lift.grad_g, m.dtype), toTensor(lift.D, m.dtype),
                           toTensor(lift.grad_D, m.dtype)};
  // One pass gives the displacement and its gradient.
  const auto [u, grad_u] = m.displacement(x, parts, true, load_scale);
  r.displacements = torch_support::toVectors(u);
  r.von_mises = torch_support::vonMisesFromGradients(grad_u, *m.material);
  return r;
}

const core::ParticleCloud& DemSolver::particles() const { return impl_->cloud; }

std::pair<double, double> DemSolver::loadRange() const {
  const Impl& m = *impl_;
  if (m.config.parametric.enabled) return {m.config.parametric.load_range_min, m.config.parametric.load_range_max};
  return {m.fraction, m.fraction};
}

void DemSolver::setProgressCallback(std::function<void(int iteration)> callback, int every) {
  impl_->progress = std::move(callback);
  impl_->progress_every = every;
}

DemSolver::~DemSolver() = default;
DemSolver::DemSolver(DemSolver&&) noexcept = default;

}  // namespace demnerf::mechanics
