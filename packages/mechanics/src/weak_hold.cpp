#include "weak_hold.hpp"

#include <algorithm>
#include <limits>

namespace demnerf::mechanics {
namespace {

// The unknowns whose value is below `ratio` (relative values), and their count.
std::vector<char> flagBelow(const Eigen::VectorXd& relative, double ratio, long& count) {
  std::vector<char> weak(static_cast<std::size_t>(relative.size()), 0);
  count = 0;
  for (Eigen::Index k = 0; k < relative.size(); ++k) count += weak[k] = relative(k) < ratio;
  return weak;
}

// The Hessian's diagonal relative to its mean: the old hold's measure, which sees the distance
// factor D and so flags the clamp's nodes as well as the ones the body barely covers.
Eigen::VectorXd relativeDiagonal(const Eigen::SparseMatrix<double>& hessian) {
  Eigen::VectorXd diagonal = hessian.diagonal().cwiseAbs();
  const double mean = std::max(diagonal.mean(), std::numeric_limits<double>::min());
  return diagonal / mean;
}

}  // namespace

Eigen::VectorXd relativeCover(const GridFieldProblem& problem, const BsplineGrid& grid, const std::vector<long>& active,
                              const Unknowns& unknowns) {
  std::vector<long> position(static_cast<std::size_t>(grid.nodeCount()), -1);
  for (std::size_t l = 0; l < active.size(); ++l) position[active[l]] = static_cast<long>(l);
  const int support = grid.supportSize();
  std::vector<long> nodes(support);
  std::vector<double> values(support);
  std::vector<Eigen::Vector3d> gradients(support);
  Eigen::VectorXd node_cover = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(active.size()));
  for (std::size_t q = 0; q < problem.points.size(); ++q) {
    grid.evaluate(problem.points[q], nodes.data(), values.data(), gradients.data());
    for (int s = 0; s < support; ++s)
      if (position[nodes[s]] >= 0) node_cover(position[nodes[s]]) += problem.volume[q] * values[s] * values[s];
  }
  const Eigen::VectorXd cover =
      unknowns.extended() ? Eigen::VectorXd(unknowns.nodeMap().cwiseAbs2().transpose() * node_cover) : node_cover;
  const double mean = std::max(cover.mean(), std::numeric_limits<double>::min());
  Eigen::VectorXd relative(3 * cover.size());
  for (Eigen::Index r = 0; r < cover.size(); ++r) relative.segment<3>(3 * r).setConstant(cover(r) / mean);
  return relative;
}

// Only for a Hessian found singular: holding the weak unknowns always stiffened a clamped cantilever
// by 2.7 % in energy and put the T-bar 5.8 % off (the weak unknowns beside a clamp carry its field),
// and damping them alone instead stalled their own convergence on clean bodies ("Ragged bodies").
void holdWeak(const std::vector<char>& weak, Eigen::VectorXd& gradient, Eigen::SparseMatrix<double>* hessian) {
  if (weak.empty()) return;
  for (Eigen::Index k = 0; k < gradient.size(); ++k)
    if (weak[k]) gradient(k) = 0.0;
  if (!hessian || hessian->nonZeros() == 0) return;
  const double mean = std::max(hessian->diagonal().cwiseAbs().mean(), std::numeric_limits<double>::min());
  for (int col = 0; col < hessian->outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(*hessian, col); it; ++it)
      if (weak[it.row()] || weak[it.col()]) it.valueRef() = it.row() == it.col() ? mean : 0.0;
}

// The ladder, narrowest first, until a factorisation no longer finds the held Hessian singular:
//   1. unknowns the quadrature barely covers (relative cover below weak_cover): the slivers of a
//      ragged surface, whose few points cannot give their functions a stiffness of full rank;
//   2. the cover below weak_stiffness (takes in rung 1's);
//   3. the old hold, exactly: every unknown whose diagonal is below weak_stiffness of the mean,
//      which takes in the clamp's nodes (the distance factor D leaves them little stiffness), only
//      when nothing narrower made the Hessian regular. (Its union with rung 2 held 3,892 unknowns
//      on a carved fox where the old hold held 3,130, and gave another, far stiffer answer.)
// On the NeRF T-bar's Poisson 1/6 cloud at extension fill 0.02 the old hold froze 1,438 of 14,151
// unknowns (611 of them the clamp's) and stiffened the answer by 0.76 points of energy
// (docs/dem_feature_grid.md, "The weak-unknown hold, narrowed").
Eigen::VectorXd weakHoldStep(ShiftedCholesky& solver, Eigen::SparseMatrix<double>& hessian, Eigen::VectorXd& gradient,
                             const GridNewtonConfig& config, const WeakHoldInputs& inputs, WeakHold& hold) {
  Eigen::VectorXd step = solver.solve(hessian, -gradient, config.initial_shift);
  if (hold.rung >= 3 || !solver.singular() || !(config.weak_stiffness > 0)) return step;
  Eigen::SparseMatrix<double> free_hessian = hessian;
  Eigen::VectorXd free_gradient = gradient;
  if (hold.held > 0) inputs.free_derivatives(free_gradient, free_hessian);
  const Eigen::VectorXd covered = inputs.cover();
  // Not only at the first iteration: a fine grid started from a coarse answer factorises its first
  // Hessian unshifted (near_minimum) and met the singularity later (a fox sponge: residual falling
  // 0.7x per iteration under the shift). And a narrow rung's Hessian found singular again at a later
  // iterate climbs on: left to the shift, Newton crawled on a closed fox sponge (residual 0.96
  // after 30 iterations, 66 factorisations).
  const int first = hold.rung > 0 ? hold.rung + 1 : std::max(1, std::min(hold.first_rung, 3));
  for (hold.rung = first; hold.rung <= 3; ++hold.rung) {
    long count = 0;
    const double ratio = hold.rung == 1 ? config.weak_cover : config.weak_stiffness;
    std::vector<char> weak = flagBelow(hold.rung == 3 ? relativeDiagonal(free_hessian) : covered, ratio, count);
    if (count == 0 || weak == hold.weak) continue;  // this rung holds nothing, or nothing new
    // Each rung holds its own set on the Hessian as assembled.
    hold.weak = std::move(weak);
    hold.held = count;
    hessian = free_hessian;
    gradient = free_gradient;
    holdWeak(hold.weak, gradient, &hessian);
    // The last rung takes the step as the hold always did (the last factor preconditions it).
    // A narrower one stays only if the held Hessian factorises unshifted (positive definite: the
    // factor then solves it in one CG step); one that does not costs that one factorisation, and a
    // load ramp's later calls on the same unknowns start at the rung the last one needed.
    if (hold.rung == 3 || solver.factoriseUnshifted(hessian))
      return solver.solve(hessian, -gradient, config.initial_shift);
  }
  hold.rung = 3;  // the old hold's set was a narrower rung's, or empty
  return hold.held > 0 ? solver.solve(hessian, -gradient, config.initial_shift) : step;
}

}  // namespace demnerf::mechanics
