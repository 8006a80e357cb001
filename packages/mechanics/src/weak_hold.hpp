#pragma once
// The grid Newton's weak-unknown hold (grid_field_newton.cpp): when a factorisation finds the
// Hessian singular, which unknowns are held where they are, and how they are held. Private to
// packages/mechanics/src.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <functional>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"
#include "extended_unknowns.hpp"
#include "shifted_cholesky.hpp"

namespace demnerf::mechanics {

/// The unknowns held in one minimiseGridField call.
struct WeakHold {
  int first_rung = 0;      ///< the ladder starts at this rung (an earlier call's on the same unknowns; 0: the first)
  std::vector<char> weak;  ///< per unknown; empty while none is held
  long held = 0;           ///< how many are held now
  int rung = 0;            ///< the ladder's last rung tried (weakHoldStep; 0: the Hessian was never singular)
  long released = 0;       ///< held, then let go at the held equilibrium (grid_field_newton.cpp, releaseHeld)
};

/// Per unknown (3 per unknown node): the cover sum_q w_q N(q)^2 of its grid function over the volume
/// points, relative to the mean over the unknowns. An extended unknown's function is its own plus
/// the extrapolated ones (bspline_extension.hpp) mapped on it, their covers weighted by the map's
/// squares (the cross terms are left out: a measure of support, not the exact integral). Unlike
/// the Hessian's diagonal it does not see the fixtures' distance factor D.
Eigen::VectorXd relativeCover(const GridFieldProblem& problem, const BsplineGrid& grid, const std::vector<long>& active,
                              const Unknowns& unknowns);

/// Holds the flagged unknowns where they are: no gradient, no coupling and the mean diagonal as
/// pivot, so the factorisation needs no shift for them and the residual is the other unknowns'.
void holdWeak(const std::vector<char>& weak, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>* hessian);

/// What the ladder needs only when it runs: relativeCover, and the gradient and Hessian at the
/// iterate without any hold (a later rung replaces an earlier one's set; the Newton's own are held).
struct WeakHoldInputs {
  std::function<Eigen::VectorXd()> cover;
  std::function<void(Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>& hessian)> free_derivatives;
};

/// The Newton step, holding weak unknowns whenever a factorisation finds the Hessian singular and
/// a wider rung is left (grid_field_newton.hpp, weak_cover).
Eigen::VectorXd weakHoldStep(ShiftedCholesky& solver, Eigen::SparseMatrix<double>& hessian, Eigen::VectorXd& gradient,
                             const GridNewtonConfig& config, const WeakHoldInputs& inputs, WeakHold& hold);

}  // namespace demnerf::mechanics
