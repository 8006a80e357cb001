#include "demnerf/mechanics/patch_response.hpp"

#include <chrono>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"

namespace demnerf::mechanics {
namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Eigen::MatrixXd asMatrix(const std::vector<Eigen::Vector3d>& u) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(u.size()), 3);
  for (std::size_t i = 0; i < u.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = u[i].transpose();
  return m;
}

bool sameRegion(const core::Region& a, const core::Region& b) {
  return a.type == b.type && a.center == b.center && a.size == b.size && a.radius == b.radius && a.normal == b.normal;
}

// Nothing but the wrench drives the base: its answer without wrench is zero.
bool restsWithoutWrench(const core::Scenario& base) {
  if (!base.body_force.isZero()) return false;
  for (const auto& fixture : base.fixtures)
    if (!fixture.displacement.isZero()) return false;
  return true;
}

// Component k of the wrench (0-2 force, 3-5 torque).
double component(const Eigen::Vector3d& force, const Eigen::Vector3d& torque, int k) {
  return k < 3 ? force[k] : torque[k - 3];
}

}  // namespace

PatchResponse::PatchResponse(core::ParticleCloud cloud, core::Scenario base, core::Region patch, DemConfig dem,
                             PatchResponseConfig config)
    : cloud_(std::move(cloud)), base_(std::move(base)), patch_(patch), dem_(std::move(dem)), config_(config) {
  if (!(config_.force_range > 0.0) || !(config_.torque_range >= 0.0) || !std::isfinite(config_.force_range) ||
      !std::isfinite(config_.torque_range))
    throw core::Error("patch response: force_range must be > 0 and torque_range >= 0 (finite)");
  if (dem_.parametric.enabled) throw core::Error("patch response: superposes grid-Newton solves; parametric mode does not apply");
  cloud_.validate();
  validateProblem(scenarioFor(Eigen::Vector3d(config_.force_range, 0, 0), Eigen::Vector3d::Zero()), cloud_);
}

PatchResponse::~PatchResponse() = default;

core::Scenario PatchResponse::scenarioFor(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const {
  core::Scenario scenario = base_;
  core::Load load;
  load.name = "patch wrench";
  load.region = patch_;
  load.force = force;
  load.torque = torque;
  scenario.loads = {load};
  return scenario;
}

core::ResultField PatchResponse::fullSolve(const core::Scenario& scenario, const SolveControl& control,
                                           double* energy) {
  try {
    if (solver_) {
      solver_->setScenario(scenario);
    } else {
      solver_ = std::make_unique<DemSolver>(cloud_, scenario, dem_, control);  // set-up within the budget
    }
    solver_->setControl(control);
    const DemReport report = solver_->solve();
    if (energy) *energy = report.energy;
    return solver_->result();
  } catch (...) {
    solver_.reset();  // half-solved: the next one starts cold
    throw;
  }
}

// The wrench with components a_k e_k for k in `ks` (a_k the range's bound).
void PatchResponse::unitWrench(std::initializer_list<int> ks, double sign, Eigen::Vector3d& force,
                               Eigen::Vector3d& torque) const {
  Eigen::Matrix<double, 6, 1> w = Eigen::Matrix<double, 6, 1>::Zero();
  for (int k : ks) w[k] = sign * (k < 3 ? config_.force_range : config_.torque_range);
  force = w.head<3>();
  torque = w.tail<3>();
}

Eigen::MatrixXd PatchResponse::solveFor(std::initializer_list<int> ks, double sign, const SolveControl& control) {
  Eigen::Vector3d force, torque;
  unitWrench(ks, sign, force, torque);
  ++solves_;
  return asMatrix(fullSolve(scenarioFor(force, torque), control).displacements);
}

void PatchResponse::prepare(const SolveControl& control) {
  const auto start = std::chrono::steady_clock::now();
  const int components = config_.torque_range > 0.0 ? 6 : 3;
  std::vector<Eigen::MatrixXd> linear, quadratic, plus, cross;
  solves_ = 0;
  // The expansion is about the base's own state (body force, moved fixtures), u(0).
  const Eigen::MatrixXd rest = restsWithoutWrench(base_) ? Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(cloud_.size()), 3)
                                                         : solveFor({}, 1.0, control);
  for (int k = 0; k < components; ++k) {
    const double a = k < 3 ? config_.force_range : config_.torque_range;
    plus.push_back(solveFor({k}, 1.0, control));
    const Eigen::MatrixXd minus = solveFor({k}, -1.0, control);
    // u(s) ~ L s + Q s^2 through u(a) and u(-a).
    linear.push_back((plus[k] - minus) / (2.0 * a));
    quadratic.push_back((plus[k] + minus - 2.0 * rest) / (2.0 * a * a));
  }
  for (int i = 0; config_.cross_terms && i < components; ++i)
    for (int j = i + 1; j < components; ++j) {
      const double ai = i < 3 ? config_.force_range : config_.torque_range;
      const double aj = j < 3 ? config_.force_range : config_.torque_range;
      // u(a_i, a_j) - u(a_i) - u(a_j) leaves the mixed second-order term B_ij a_i a_j.
      cross.push_back((solveFor({i, j}, 1.0, control) - plus[i] - plus[j] + rest) / (ai * aj));
    }
  linear_ = std::move(linear);
  quadratic_ = std::move(quadratic);
  cross_ = std::move(cross);
  rest_ = rest;
  preparation_seconds_ = secondsSince(start);
}

bool PatchResponse::covers(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const {
  if (!force.allFinite() || !torque.allFinite()) return false;
  const bool torque_ok = config_.torque_range > 0.0 ? torque.cwiseAbs().maxCoeff() <= config_.torque_range
                                                    : torque.isZero(0.0);
  return prepared() && force.cwiseAbs().maxCoeff() <= config_.force_range && torque_ok;
}

bool PatchResponse::answersFor(const core::Scenario& scenario) const {
  const core::Material &a = scenario.material, &b = base_.material;
  if (a.model != b.model || a.youngs_modulus != b.youngs_modulus || a.poisson_ratio != b.poisson_ratio ||
      scenario.body_force != base_.body_force || scenario.fixtures.size() != base_.fixtures.size() ||
      scenario.loads.size() != 1 || !sameRegion(scenario.loads.front().region, patch_))
    return false;
  for (std::size_t i = 0; i < scenario.fixtures.size(); ++i) {
    const core::Fixture &f = scenario.fixtures[i], &g = base_.fixtures[i];
    if (!sameRegion(f.region, g.region) || f.displacement != g.displacement || f.constrained != g.constrained)
      return false;
  }
  return true;
}

core::ResultField PatchResponse::superpose(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const {
  if (!prepared()) throw core::Error("patch response: prepare() has not run");
  if (!covers(force, torque)) throw core::Error("patch response: the wrench lies outside the prepared range");
  Eigen::MatrixXd u = rest_;
  const int components = static_cast<int>(linear_.size());
  for (int k = 0; k < components; ++k) {
    const double s = component(force, torque, k);
    if (s != 0.0) u += s * linear_[k] + (s * s) * quadratic_[k];
  }
  std::size_t pair = 0;
  for (int i = 0; i < components && !cross_.empty(); ++i)
    for (int j = i + 1; j < components; ++j, ++pair) {
      const double s = component(force, torque, i) * component(force, torque, j);
      if (s != 0.0) u += s * cross_[pair];
    }
  core::ResultField field;
  field.resize(cloud_.size());
  field.positions = cloud_.positions;
  for (std::size_t i = 0; i < cloud_.size(); ++i) field.displacements[i] = u.row(static_cast<Eigen::Index>(i)).transpose();
  return field;
}

PatchAnswer PatchResponse::answer(const Eigen::Vector3d& force, const Eigen::Vector3d& torque,
                                  const SolveControl& control) {
  const auto start = std::chrono::steady_clock::now();
  PatchAnswer answer;
  if (covers(force, torque)) {
    answer.field = superpose(force, torque);
    answer.path = "basis";
  } else {
    answer.field = fullSolve(scenarioFor(force, torque), control, &answer.energy);
    answer.path = "full";
  }
  answer.seconds = secondsSince(start);
  return answer;
}

}  // namespace demnerf::mechanics
