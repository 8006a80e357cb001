#pragma once
// Newton's method on the coefficients of the DEM's B-spline feature grid.
//
// With the exact Dirichlet construction the DEM field is u = u_0(X) + D(X) o (N(X) C): u_0 holds
// everything that is not the grid (the lift and the MLP's share), D the distance factor per
// component, N the grid's basis functions and C their coefficients (one row per grid node). u and
// Grad u are linear in C, so the potential energy restricted to C is a smooth problem whose
// Hessian is sparse (a node couples only with nodes whose supports overlap): Newton's method with
// a sparse Cholesky factorisation solves it in a few iterations, where Adam needs thousands of
// steps for the same field. Eigen only: no torch in this file.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/material.hpp"

namespace demnerf::mechanics {

/// The quadrature points of the energy and of the loaded surface, with the fixed part of the field.
/// Loads are those of the current load fraction.
struct GridFieldProblem {
  std::vector<Eigen::Vector3d> points;       ///< volume quadrature points
  std::vector<double> volume;                ///< their weights (m^3)
  std::vector<Eigen::Vector3d> body;         ///< body force times volume (N)
  std::vector<Eigen::Vector3d> offset;       ///< u_0 at the points (m)
  std::vector<Eigen::Matrix3d> grad_offset;  ///< (i, k) = d u_0,i / d X_k
  std::vector<Eigen::Vector3d> D;            ///< distance factor per component
  std::vector<Eigen::Matrix3d> grad_D;       ///< (i, k) = d D_i / d X_k
  std::vector<Eigen::Vector3d> surface_points, surface_offset, surface_D;
  std::vector<Eigen::Vector3d> surface_force;  ///< traction times area (N)
};

/// What one minimiseGridField call hands to the next on the same grid and quadrature: the
/// elimination order and the last factorisation, which then preconditions the next call's first
/// Newton steps instead of a new factorisation per call. Repeated solves of one body (a load
/// ramp's steps, a patch basis' 27 small-load solves) are dominated by factorisations otherwise.
/// Used only while the unknowns are the same; a different set resets it.
class GridNewtonCache {
 public:
  GridNewtonCache();
  ~GridNewtonCache();
  GridNewtonCache(GridNewtonCache&&) noexcept;
  GridNewtonCache& operator=(GridNewtonCache&&) noexcept;

  struct State;  // grid_field_newton.cpp
  std::unique_ptr<State> state;
};

struct GridNewtonConfig {
  int max_iterations = 30;
  /// Converged when the residual (the energy's gradient in C, the discrete weak form) is below
  /// this fraction of the load it balances: |dPi/dC| <= residual_tolerance * max(|f_ext|, |dPi/dC|
  /// at the start)). The first-order condition, not a small step: a step can be small far from
  /// an equilibrium when the Hessian had to be shifted.
  double residual_tolerance = 1e-6;
  /// A Newton decrement below this fraction of max(|Pi|, strain energy) is below the energy's
  /// rounding: such steps skip the line search (at most 3 of them; convergence is the residual's).
  double tolerance = 1e-12;
  /// Smallest diagonal shift, relative to each column's own diagonal, when the Hessian is not
  /// positive definite (far from the minimum of the nonconvex energy; shifted_cholesky.hpp).
  double initial_shift = 1e-6;
  /// Extended B-splines (bspline_extension.hpp): nodes whose support holds no grid cell filled to
  /// at least this share by the quadrature are extrapolated from a nearby filled cell instead of
  /// being unknowns (0: every node the quadrature sees is an unknown).
  double extension_fill = 0.0;
  /// When a factorisation first finds the Hessian singular (no negative curvature, yet not
  /// positive definite), weak unknowns are held where they are (no step, not in the residual):
  /// grid functions the body barely sees, and the shift of every column that would cover them
  /// stalls the body's soft modes (a ragged NeRF body; docs/dem_feature_grid.md, "Ragged bodies").
  /// Narrowest first, until a factorisation finds the held Hessian no longer singular: the
  /// unknowns whose cover (sum of w N^2 over the points, relative to the mean) is below
  /// weak_cover, then below weak_stiffness, then also those whose Hessian diagonal is below
  /// weak_stiffness of the mean (the clamp's nodes, which the distance factor D leaves little
  /// stiffness; "The weak-unknown hold, narrowed"). weak_stiffness 0: never held.
  double weak_stiffness = 1e-3;
  /// The first rung's cover ratio (functions only slivers reach; 0: the ladder starts at the second).
  double weak_cover = 1e-6;
  /// At the held equilibrium, the held unknowns are let go (and Newton goes on) when the Hessian
  /// without the hold factorises unshifted there: the singularity was the start's, not the body's.
  bool release_held = true;
  /// The Newton starts near its minimum (the nested solve's fine grid, started from a coarse
  /// grid's answer): a new factorisation is tried without a shift before Lanczos looks for one.
  bool near_minimum = false;
  /// The first Newton step's Hessian takes the points' strongly indefinite tangents dP/dF projected
  /// positive semidefinite (grid_field_energy.hpp). For a start moved from another grid (the nested
  /// solve's fine grid), whose field at a few cut-cell points is compressed (80 of 160k points, det
  /// F 0.83, on a NeRF T-bar at 7.88 mm) and makes the exact Hessian indefinite: its failed
  /// factorisation, Lanczos' shift and the shifted steps cost 3 factorisations instead of 1. Later
  /// steps use the exact Hessian, so the answer and the convergence test are unchanged.
  bool projected_start = false;
  /// Threads of the assembly and the energy evaluations (0: every core).
  int threads = 0;
  /// Called after each assembly with the iteration, the energy and the relative residual; it may
  /// throw (a time limit, a cancel): C then holds the last accepted coefficients.
  std::function<void(int iteration, double energy, double residual)> on_iteration;
  /// Kept between calls by the caller (nullptr: every call factorises afresh).
  GridNewtonCache* cache = nullptr;
};

struct GridNewtonOutcome {
  double energy = 0.0;   ///< potential energy at the returned coefficients (J)
  double strain_energy = 0.0;
  double min_J = 0.0;
  int iterations = 0;
  double residual = 0.0;  ///< |dPi/dC| / load at the returned coefficients (see residual_tolerance)
  bool converged = false;
  long held = 0;          ///< weak unknowns held at the answer (GridNewtonConfig::weak_stiffness)
  long released = 0;      ///< weak unknowns held, then let go (GridNewtonConfig::release_held)
  int hold_rung = 0;      ///< the weak hold's last rung tried (1-3; 0: the Hessian was never singular)
  int factorisations = 0; ///< sparse (or dense) factorisations of this call, failed ones included
  /// |dPi/dC| / load over the held unknowns alone at the returned coefficients: what `residual`,
  /// which leaves them out, does not see (0 when none is held)
  double held_residual = 0.0;
  double assembly_seconds = 0.0, factorisation_seconds = 0.0, line_search_seconds = 0.0;
};

/// Minimises the potential energy over C (grid.nodeCount() x 3), starting from C; C only ever
/// moves to states of lower energy with every det F > 0, so the result is never worse than the
/// start. Nodes no quadrature point sees stay as they are.
GridNewtonOutcome minimiseGridField(const GridFieldProblem& problem, const HyperelasticMaterial& material,
                                    const BsplineGrid& grid, Eigen::MatrixXd& C, const GridNewtonConfig& config = {});

}  // namespace demnerf::mechanics
