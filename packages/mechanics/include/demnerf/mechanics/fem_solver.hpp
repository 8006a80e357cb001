#pragma once
// The full-order FEM baseline: total Lagrangian tetrahedra (4 or 10 nodes), Newton-Raphson with
// a backtracking line search and adaptive load steps, Eigen sparse linear solvers on a sparsity
// pattern built once, threaded deterministic assembly.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

/// The FEM baseline's settings; why each default is what it is: docs/dem_config.md ("FemConfig").
struct FemConfig {
  enum class LinearSolver { kLDLT, kConjugateGradient };
  LinearSolver linear_solver = LinearSolver::kLDLT;  ///< sparse solver of each Newton step (kLDLT)
  /// Fill-reducing order of the LDLT: approximate minimum degree on the dofs, or geometric nested
  /// dissection of the mesh nodes (kAmd).
  enum class Ordering { kNestedDissection, kAmd };
  Ordering ordering = Ordering::kAmd;
  int max_newton_iterations = 25;  ///< Newton iterations per load step (25)
  int load_steps = 1;              ///< load increments; 0: the scenario's; a failed step is halved (1)
  int threads = 0;                 ///< assembly and line-search threads; 0: all cores; results do not depend on it (0)
  /// LDLT only: the last factorisation preconditions CG until CG needs more than this many
  /// iterations; 0: factorise every Newton step (30).
  int reuse_factorisation_iterations = 30;
  double tolerance = 1e-9;               ///< converged at |residual| <= this x (|external| + |internal| forces)
  double displacement_tolerance = 1e-8;  ///< ...or when the last update is below this x |u| (round-off bound loads)
  int max_step_halvings = 8;             ///< halvings of a load step whose Newton loop fails (8)
  double cg_tolerance = 1e-12;           ///< relative tolerance of the CG solves
  bool verbose = false;
};

/// Displacement of a point cloud computed by the FEM, with von Mises stress.
struct PointField {
  std::vector<Eigen::Vector3d> displacement;
  std::vector<double> von_mises;
};

struct FemResult {
  std::vector<Eigen::Vector3d> displacement;  ///< per mesh node
  double energy = 0.0;                         ///< total potential energy at full load
  int newton_iterations = 0;                   ///< over all load steps
  int load_steps = 0;                          ///< taken, halvings included
  int factorisations = 0;                      ///< sparse LDLT factorisations
  int cg_iterations = 0;                       ///< preconditioned CG iterations (reused factors)
  double residual = 0.0;                       ///< final |residual| / |external load| (free dofs)
  double seconds = 0.0;
  double assembly_seconds = 0.0, factorisation_seconds = 0.0, solve_seconds = 0.0, line_search_seconds = 0.0;
};

class FemSolver {
 public:
  /// Resolves fixtures (nodes inside fixture regions) and loads (boundary faces whose centroid
  /// lies in the load region; traction with the load's exact force and torque); throws
  /// core::Error for bad scenarios, degenerate elements, or regions that select nothing.
  FemSolver(TetMesh mesh, const core::Scenario& scenario, FemConfig config = {});
  ~FemSolver();
  FemSolver(FemSolver&&) noexcept;

  /// Applies the scenario in config.load_steps increments (halved on failure), with no time limit
  /// and no progress reports. Throws SolveError (a core::Error) when Newton cannot converge even
  /// with the smallest step: kInverted when every try inverted elements, kNotConverged otherwise,
  /// kDegenerate when nothing is held; the solver then keeps the last converged load fraction's
  /// state (result().displacement).
  const FemResult& solve();
  /// The same under a time budget, progress sink and cancel flag: one report per Newton iteration
  /// at most every control.progress_interval (load fraction, iteration, energy, |r| / |f_ext|),
  /// and control.check() between Newton iterations (SolveError kTimeLimit / kCancelled).
  const FemResult& solve(const SolveControl& control);
  /// The same on a clock the caller started, so that time spent before the solve (meshing)
  /// counts against the budget.
  const FemResult& solve(SolveClock& clock);
  const FemResult& result() const;
  const TetMesh& mesh() const;
  /// Displacement and von Mises stress at points: interpolated in the containing element, or
  /// the nearest one for points slightly outside the mesh.
  PointField interpolate(const std::vector<Eigen::Vector3d>& points) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::mechanics
