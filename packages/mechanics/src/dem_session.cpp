#include "demnerf/mechanics/dem_session.hpp"

#include <chrono>
#include <cmath>
#include <optional>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"

namespace demnerf::mechanics {
namespace {

bool sameRegion(const core::Region& a, const core::Region& b) {
  return a.type == b.type && a.center == b.center && a.size == b.size && a.radius == b.radius && a.normal == b.normal;
}

bool sameMaterial(const core::Material& a, const core::Material& b) {
  return a.model == b.model && a.youngs_modulus == b.youngs_modulus && a.poisson_ratio == b.poisson_ratio;
}

// Pairs of (reference vector, scaled vector) whose common factor decides the load scale.
struct Pairs {
  double dot = 0.0, ref2 = 0.0;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> items;
  void add(const Eigen::Vector3d& ref, const Eigen::Vector3d& scaled) {
    dot += ref.dot(scaled);
    ref2 += ref.squaredNorm();
    items.emplace_back(ref, scaled);
  }
};

// The budget a new network gets after a warm start failed with `failure`, or nothing when a new
// network cannot do better: the budget is spent, the user cancelled, or the set-up itself cannot
// have an equilibrium.
std::optional<SolveControl> retryControl(const SolveError& failure, const SolveControl& control,
                                         std::chrono::steady_clock::time_point start) {
  if (failure.failure() != SolveFailure::kNotConverged && failure.failure() != SolveFailure::kInverted) return std::nullopt;
  SolveControl rest = control;
  if (control.time_limit > 0) {
    rest.time_limit = control.time_limit - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!(rest.time_limit > 0)) return std::nullopt;
  }
  return rest;
}

}  // namespace

std::optional<double> loadScaleBetween(const core::Scenario& reference, const core::Scenario& scaled,
                                       double tolerance) {
  if (!sameMaterial(reference.material, scaled.material) || reference.loads.size() != scaled.loads.size() ||
      reference.fixtures.size() != scaled.fixtures.size())
    return std::nullopt;
  Pairs pairs;
  for (std::size_t i = 0; i < reference.loads.size(); ++i) {
    const core::Load &a = reference.loads[i], &b = scaled.loads[i];
    if (!sameRegion(a.region, b.region)) return std::nullopt;
    pairs.add(a.force, b.force);
    pairs.add(a.torque, b.torque);
  }
  for (std::size_t i = 0; i < reference.fixtures.size(); ++i) {
    const core::Fixture &a = reference.fixtures[i], &b = scaled.fixtures[i];
    if (!sameRegion(a.region, b.region) || a.constrained != b.constrained) return std::nullopt;
    pairs.add(a.displacement, b.displacement);
  }
  pairs.add(reference.body_force, scaled.body_force);
  if (!(pairs.ref2 > 0)) return std::nullopt;  // nothing to scale: a load-free reference
  const double s = pairs.dot / pairs.ref2;
  for (const auto& [ref, other] : pairs.items)
    if ((other - s * ref).norm() > tolerance * std::sqrt(pairs.ref2)) return std::nullopt;
  return s;
}

DemSession::DemSession(DemConfig config) : config_(std::move(config)) {}

void DemSession::setParticles(core::ParticleCloud cloud) {
  cloud.validate();
  cloud_ = std::move(cloud);
  solver_.reset();
}

// Trains the kept network (warm) or a new one (cold, when none is kept) on `scenario`. After a
// failure none is kept: half-trained for a load case it failed on, the next answer starts cold.
void DemSession::train(const core::Scenario& scenario, const SolveControl& control, DemSessionAnswer& answer) {
  try {
    if (solver_) {
      answer.mode = "warm";
      solver_->setScenario(scenario);
    } else {
      answer.mode = "cold";
      solver_ = std::make_unique<DemSolver>(*cloud_, scenario, config_, control);  // set-up within the budget
    }
    solver_->setControl(control);
    const DemReport report = solver_->solve();
    answer.outcome.energy = report.energy;
    unverified_ = report.unverified;
    coarse_grid_ = report.coarse_grid;
    answer.outcome.field = solver_->result();
    trained_ = scenario;
  } catch (...) {
    solver_.reset();
    throw;
  }
}

DemSessionAnswer DemSession::answer(const core::Scenario& scenario) { return answer(scenario, SolveControl{}); }

DemSessionAnswer DemSession::answer(const core::Scenario& scenario, const SolveControl& control) {
  if (!cloud_) throw core::Error("DEM: no particles yet (the particle cloud has not arrived)");
  const auto start = std::chrono::steady_clock::now();
  DemSessionAnswer answer;
  if (solver_ && config_.parametric.enabled) {
    const auto s = loadScaleBetween(trained_, scenario);
    const auto [lo, hi] = solver_->loadRange();
    if (s && *s >= lo && *s <= hi) {
      validateProblem(scenario, *cloud_);  // the training paths below validate in the solver
      answer.mode = "instant";
      answer.load_scale = *s;
      answer.outcome.field = solver_->evaluate(cloud_->positions, *s);
    } else if (!(s && *s > 0)) {
      // The parametric network holds the trained load's field over its whole range, a worse start
      // for a load in another direction than a new network: on the rostests' 99-particle bar, a
      // wrench turned by 90 degrees reached -1.20e-7 J warm and -2.67e-7 J cold after the same 1200
      // Adam steps, and on one machine the warm answer failed the energy check (the parametric
      // rostest, 4 runs of 4). A load beyond the range in the trained direction stays warm-started.
      solver_.reset();
    }
  }
  if (answer.mode.empty()) {
    const bool warm = solver_ != nullptr;
    try {
      train(scenario, control, answer);
    } catch (const SolveError& e) {
      // A warm start that ends in no equilibrium is tried once more on a new network, within what
      // is left of the budget: the MLP alone on the rostests' 99-particle bar, trained for a 20 mN
      // tip force and asked for it turned by 90 degrees, was refused warm ("exploited its Gauss
      // points") and answered by a new network (-7.60e-6 J).
      const std::optional<SolveControl> rest = warm ? retryControl(e, control, start) : std::nullopt;
      if (!rest) throw;
      answer.warm_failure = e.what();
      train(scenario, *rest, answer);
    }
  }
  for (const auto& u : answer.outcome.field.displacements)
    answer.outcome.max_displacement = std::max(answer.outcome.max_displacement, u.norm());
  answer.outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  answer.unverified = unverified_;
  answer.outcome.coarse_grid = coarse_grid_;  // instant answers scale the same training
  return answer;
}

}  // namespace demnerf::mechanics
