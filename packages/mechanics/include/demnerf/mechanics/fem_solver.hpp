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

struct FemConfig {
  enum class LinearSolver { kLDLT, kConjugateGradient };
  LinearSolver linear_solver = LinearSolver::kLDLT;
  /// Fill-reducing order of the LDLT: Eigen's approximate minimum degree on the dofs (default),
  /// or a geometric nested dissection of the mesh nodes (more fill than AMD on the T-bar meshes
  /// measured so far: nnz(L) 15.7M vs 12.7M; kept for larger meshes and comparisons).
  enum class Ordering { kNestedDissection, kAmd };
  Ordering ordering = Ordering::kAmd;
  int max_newton_iterations = 25;
  /// Load increments; 0 takes the scenario's load_steps. A hyperelastic answer does not depend
  /// on the load path, and Newton with the energy line search takes the T-bar twist in one step
  /// (16 iterations vs 27 in the scenario's 4): a step that fails is halved, later steps start
  /// from a secant predictor.
  int load_steps = 1;
  /// Threads for element assembly and the line search's energy evaluations (0: all cores, the
  /// default). Results do not depend on the count:
  /// elements are coloured so that no two in a colour share a node, and each colour is summed in
  /// order. The sparse LDLT (Eigen's SimplicialLDLT) and its triangular solves run on one core;
  /// the factorisation reuse below keeps factorisations to a few per solve.
  int threads = 0;
  /// LDLT only: solve with preconditioned CG using the last factorisation as preconditioner and
  /// refactorise only when CG needs more than this many iterations (0: factorise every Newton step).
  int reuse_factorisation_iterations = 30;
  /// Converged when |residual| <= tolerance * (|external forces| + |internal forces|).
  double tolerance = 1e-9;
  /// ...or when the last Newton update is below this fraction of |u| (round-off bound loads).
  double displacement_tolerance = 1e-8;
  /// A load step whose Newton loop fails is halved up to this many times.
  int max_step_halvings = 8;
  double cg_tolerance = 1e-12;
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
