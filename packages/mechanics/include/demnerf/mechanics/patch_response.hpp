#pragma once
// Instant answers for any wrench on one contact patch (issue 17, item 2). A one-time preparation
// solves the DEM (feature grid + Newton) for each of the six wrench components at +a and -a (a the
// range's bound), which gives each component's linear and quadratic response, and for each pair
// of components at (+a, +a), which gives their cross term. A new wrench in the range is then the
// second-order expansion u(w) = sum_k (L_k w_k + Q_k w_k^2) + sum_{i<j} B_ij w_i w_j: no solve,
// a few multiply-adds per particle. Third-order terms are what remains between it and a full
// solve; bench/mechanics_patch_response.cpp measures it. Outside the range the answer is a full DEM
// solve, warm-started from the last one.

#include <Eigen/Core>
#include <initializer_list>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/solve_control.hpp"

namespace demnerf::mechanics {

struct PatchResponseConfig {
  double force_range = 1.0;   ///< N: every force component in [-force_range, force_range] is instant
  double torque_range = 0.0;  ///< N m: the same for the torque (0: torques always take a full solve)
  /// The pairs' cross terms (15 more solves with torques, 3 without); false: each component alone.
  bool cross_terms = true;
};

struct PatchAnswer {
  core::ResultField field;  ///< basis answers: displacements only (von Mises 0: not computed)
  std::string path;         ///< "basis" (superposed) or "full" (a warm-started DEM solve)
  /// Potential energy at the answer (J): the full solve's; NaN for a basis answer (not computed).
  double energy = std::numeric_limits<double>::quiet_NaN();
  double seconds = 0.0;
};

class PatchResponse {
 public:
  /// `base` gives the material and fixtures (its loads are ignored); the wrench acts on the
  /// surface particles in `patch`. Checks the problem (core::Error) but solves nothing yet.
  PatchResponse(core::ParticleCloud cloud, core::Scenario base, core::Region patch, DemConfig dem,
                PatchResponseConfig config);
  ~PatchResponse();

  /// The one-time preparation: 12 DEM solves (6 when torque_range is 0), and 15 (3) more for the
  /// cross terms. SolveError from a solve.
  void prepare(const SolveControl& control = {});
  bool prepared() const { return !linear_.empty(); }
  double preparationSeconds() const { return preparation_seconds_; }
  int preparationSolves() const { return solves_; }

  /// Whether the wrench lies in the prepared range (each component within its bound).
  bool covers(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const;
  /// Whether `scenario` is this problem with some wrench on the patch: the same material, body
  /// force and fixtures as the base, and one load whose region is the patch.
  bool answersFor(const core::Scenario& scenario) const;
  /// The superposed displacement field (core::Error when not prepared or out of range).
  core::ResultField superpose(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const;
  /// The scenario of this wrench on the patch (base material and fixtures).
  core::Scenario scenarioFor(const Eigen::Vector3d& force, const Eigen::Vector3d& torque) const;
  /// Basis when covered, else a full DEM solve warm-started from the last full one.
  PatchAnswer answer(const Eigen::Vector3d& force, const Eigen::Vector3d& torque, const SolveControl& control = {});

 private:
  core::ResultField fullSolve(const core::Scenario& scenario, const SolveControl& control, double* energy = nullptr);
  void unitWrench(std::initializer_list<int> ks, double sign, Eigen::Vector3d& force, Eigen::Vector3d& torque) const;
  /// The displacements (particles x 3) of the wrench a_k e_k summed over ks, times sign.
  Eigen::MatrixXd solveFor(std::initializer_list<int> ks, double sign, const SolveControl& control);

  core::ParticleCloud cloud_;
  core::Scenario base_;
  core::Region patch_;
  DemConfig dem_;
  PatchResponseConfig config_;
  std::unique_ptr<DemSolver> solver_;  ///< kept for warm starts
  std::vector<Eigen::MatrixXd> linear_, quadratic_;  ///< per component k: particles x 3, per unit (N or N m)
  std::vector<Eigen::MatrixXd> cross_;
  Eigen::MatrixXd rest_;  ///< the base's own answer without wrench (zero unless it has body force or moved fixtures)  ///< per pair (i < j, row-major order): particles x 3 per unit^2
  int solves_ = 0;
  double preparation_seconds_ = 0.0;
};

}  // namespace demnerf::mechanics
