// The grid Newton on a body with grid functions it barely sees, as a ragged NeRF extraction has
// them (the fox: covers of 1e-4 .. 1e-8 of a cell, most beside the fixture, where the distance
// factor cancels them). They make the Hessian singular at rest; the shift of every column that
// then covers them also damps the body's soft bending modes, and Newton crawls. Held where they
// are once the Hessian is found singular (weak_stiffness), they let the rest converge as on a
// clean body (docs/dem_feature_grid.md, "Ragged bodies").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>

#include "demnerf/mechanics/bspline_grid.hpp"
#include "demnerf/mechanics/grid_field_newton.hpp"
#include "demnerf/mechanics/material.hpp"
#include "../src/grid_field_energy.hpp"

namespace dm = demnerf::mechanics;
using Eigen::Vector3d;

namespace {

// A slender cantilever (1.2 x 0.1 x 0.1 m, clamped at x = 0 by its distance factor) pushed down at
// its tip, on 2 x 2 x 2 Gauss points per cell of 0.05 m; with `slivers`, a few points of a
// millionth of a cell's weight (a ragged surface's slivers) in cells around the bar, each the
// only point its outer grid functions see.
struct SlenderBar {
  dm::BsplineGrid grid{Vector3d(-0.1, -0.1, -0.1), Vector3d(1.3, 0.2, 0.2), 0.05, 2};
  dm::GridFieldProblem problem;

  explicit SlenderBar(bool slivers) {
    const double h = 0.05, a = 0.5 / std::sqrt(3.0);
    for (int i = 0; i < 24; ++i)
      for (int j = 0; j < 2; ++j)
        for (int k = 0; k < 2; ++k)
          for (int g = 0; g < 8; ++g)
            add(h * Vector3d(i + 0.5 + (g & 1 ? a : -a), j + 0.5 + (g & 2 ? a : -a), k + 0.5 + (g & 4 ? a : -a)),
                h * h * h / 8);
    if (slivers)
      for (int i = 2; i < 24; i += 3) {
        add(Vector3d(h * i + 0.01, 0.13, 0.05), 1e-6 * h * h * h);
        add(Vector3d(h * i + 0.02, 0.05, -0.03), 1e-6 * h * h * h);
      }
    for (int j = 0; j < 4; ++j) {  // the tip's load, 0.4 N down over its face (~5 cm deflection)
      const Vector3d x(1.2, 0.0125 + 0.025 * j, 0.05);
      problem.surface_points.push_back(x);
      problem.surface_offset.push_back(Vector3d::Zero());
      problem.surface_D.push_back(Vector3d::Constant(x(0)));
      problem.surface_force.push_back(Vector3d(0.0, 0.0, -0.1));
    }
  }

  void add(const Vector3d& x, double weight) {
    problem.points.push_back(x);
    problem.volume.push_back(weight);
    problem.body.push_back(Vector3d::Zero());
    problem.offset.push_back(Vector3d::Zero());
    problem.grad_offset.push_back(Eigen::Matrix3d::Zero());
    problem.D.push_back(Vector3d::Constant(x(0)));  // every component held at x = 0
    Eigen::Matrix3d grad_D = Eigen::Matrix3d::Zero();
    grad_D.col(0).setOnes();
    problem.grad_D.push_back(grad_D);
  }
};

dm::GridNewtonOutcome solve(const SlenderBar& bar, double weak_stiffness, Eigen::MatrixXd& C,
                            double weak_cover = dm::GridNewtonConfig{}.weak_cover) {
  demnerf::core::Material params;
  params.youngs_modulus = 5e5;
  params.poisson_ratio = 0.4;
  const auto material = dm::makeMaterial(params);
  C = Eigen::MatrixXd::Zero(bar.grid.nodeCount(), 3);
  dm::GridNewtonConfig config;
  config.max_iterations = 8;
  config.threads = 1;
  config.weak_stiffness = weak_stiffness;
  config.weak_cover = weak_cover;
  return dm::minimiseGridField(bar.problem, *material, bar.grid, C, config);
}

}  // namespace

TEST(GridNewtonWeakUnknowns, SliversOfABodyDoNotStallNewton) {
  Eigen::MatrixXd clean_C, ragged_C, unheld_C, plain_C;
  const dm::GridNewtonOutcome clean = solve(SlenderBar(false), 1e-3, clean_C);
  ASSERT_TRUE(clean.converged) << "residual " << clean.residual;
  // A clean body's Hessian is not singular: nothing is held, the answer is the plain Newton's.
  const dm::GridNewtonOutcome plain = solve(SlenderBar(false), 0.0, plain_C);
  EXPECT_EQ(clean.held, 0);
  EXPECT_EQ(clean.energy, plain.energy);
  const dm::GridNewtonOutcome ragged = solve(SlenderBar(true), 1e-3, ragged_C);
  EXPECT_TRUE(ragged.converged) << "residual " << ragged.residual << " after " << ragged.iterations;
  EXPECT_LE(ragged.iterations, clean.iterations + 2);
  EXPECT_GT(ragged.held, 0);
  // What the residual leaves out is measured, and is small: only the slivers' functions are held.
  EXPECT_EQ(clean.held_residual, 0.0);
  EXPECT_TRUE(std::isfinite(ragged.held_residual));
  EXPECT_LT(ragged.held_residual, 0.5);
  EXPECT_NEAR(ragged.energy, clean.energy, 0.05 * std::abs(clean.energy));
  EXPECT_LT(ragged.energy, 0.0);
  // Without holding them (the grid Newton before), the same body is not solved in these iterations.
  const dm::GridNewtonOutcome unheld = solve(SlenderBar(true), 0.0, unheld_C);
  EXPECT_FALSE(unheld.converged && unheld.iterations <= clean.iterations + 2)
      << "residual " << unheld.residual << " after " << unheld.iterations;
}

TEST(GridNewtonWeakUnknowns, OnlyTheSliversAreHeldNotTheClampsFunctions) {
  // The hold used to take every unknown whose Hessian diagonal was below 1e-3 of the mean, and the
  // distance factor D makes the functions beside the clamp that weak although the bar fills their
  // support: the held ones carried 4.3 % of the load and the answer was 2.9 % stiff in energy. The
  // narrow hold's first rung takes only the functions whose support holds nothing but slivers
  // (cover below 1e-6 of the mean), and that is enough to make this Hessian regular.
  Eigen::MatrixXd clean_C, ragged_C;
  const dm::GridNewtonOutcome clean = solve(SlenderBar(false), 1e-3, clean_C);
  const dm::GridNewtonOutcome ragged = solve(SlenderBar(true), 1e-3, ragged_C);
  ASSERT_TRUE(clean.converged);
  ASSERT_TRUE(ragged.converged) << "residual " << ragged.residual;
  std::cout << "clean " << clean.energy << " J; ragged " << ragged.energy << " J, " << ragged.held
            << " held (rung " << ragged.hold_rung << "), held residual " << ragged.held_residual << "\n";
  EXPECT_EQ(ragged.hold_rung, 1);
  // Each sliver point lies in the support of one layer (3 x 3) of grid nodes outside the bar's:
  // 16 points, at most 144 nodes, 432 unknowns; nothing the bar covers.
  EXPECT_GT(ragged.held, 0);
  EXPECT_LE(ragged.held, 3 * 16 * 9);
  // Still stiffer than the clean bar (measured 1.1 % in energy, held residual 1.8 %; a held
  // function fixes the field at its sliver points whatever the bar's functions there do), but
  // half the old hold's error.
  EXPECT_LT(ragged.held_residual, 0.03);
  EXPECT_GT(ragged.energy, clean.energy);
  EXPECT_LT(ragged.energy - clean.energy, 0.02 * std::abs(clean.energy));
}

namespace {

// A hold that only the start needed. A block of 2 x 2 x 2 cells (h = 1/16 m, so the grid's knots
// are exact in binary) on three symmetry planes (D = X: u_i = 0 on X_i = 0), pulled by `pull` N on
// its faces x = 2h and y = 2h: uniform biaxial tension, which the basis holds exactly. Above the
// corner cell, in the layer of cells beyond the top face, four sliver points of a thousandth of a
// cell each are all that sees the outer layer's 9 grid functions (27 unknowns). Their strains
// (4 x 6 = 24) cannot fix 27 unknowns: with no stress the points turn rigidly at no energy cost,
// and the Hessian is singular. Their whole gradients (4 x 9 = 36) do fix them, so once the points
// are stressed, the stress's own stiffness (dP/dF's geometric part) makes those turns cost energy:
// at the held equilibrium, under the pull, the Hessian without the hold is positive definite.
// u_0 squeezes the body by `squeeze` (offset -squeeze X) so that at the start those turns have a
// slightly negative curvature (about -4e-4 of the scaled diagonal, inside the band of 1e-3 the
// solver calls singular): with exact zeros, rounding alone decides whether the factorisation fails.
// Measured: every combination of sliver weight 8e-4 .. 1.2e-3, squeeze 1.5e-4 .. 2.5e-4 and pull
// 25 .. 35 N releases and converges (27 of 27).
struct SqueezedBlock {
  static constexpr double h = 0.0625;
  dm::BsplineGrid grid{Vector3d::Constant(-2 * h), Vector3d::Constant(5 * h), h, 2};
  dm::GridFieldProblem problem;
  double squeeze;

  SqueezedBlock(double pull, double squeeze_) : squeeze(squeeze_) {
    const double a = 0.5 / std::sqrt(3.0);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
        for (int k = 0; k < 2; ++k)
          for (int g = 0; g < 8; ++g)
            add(h * Vector3d(i + 0.5 + (g & 1 ? a : -a), j + 0.5 + (g & 2 ? a : -a), k + 0.5 + (g & 4 ? a : -a)),
                h * h * h / 8);
    // Scattered in the cell (0..h, 0..h, 2h..3h); the rounded draw of a random generator.
    const Vector3d slivers[4] = {{0.22, 0.89, 2.90}, {0.49, 0.34, 2.19}, {0.68, 0.16, 2.49}, {0.62, 0.79, 2.66}};
    for (const Vector3d& s : slivers) add(h * s, 1e-3 * h * h * h);
    for (int u = 0; u < 4; ++u)
      for (int v = 0; v < 4; ++v) {
        const double p = h * (u + 0.5) / 2, q = h * (v + 0.5) / 2;
        load(Vector3d(2 * h, p, q), Vector3d(pull / 16, 0.0, 0.0));
        load(Vector3d(p, 2 * h, q), Vector3d(0.0, pull / 16, 0.0));
      }
  }

  void add(const Vector3d& x, double weight) {
    problem.points.push_back(x);
    problem.volume.push_back(weight);
    problem.body.push_back(Vector3d::Zero());
    problem.offset.push_back(-squeeze * x);
    problem.grad_offset.push_back(-squeeze * Eigen::Matrix3d::Identity());
    problem.D.push_back(x);
    problem.grad_D.push_back(Eigen::Matrix3d::Identity());
  }

  void load(const Vector3d& x, const Vector3d& force) {
    problem.surface_points.push_back(x);
    problem.surface_offset.push_back(-squeeze * x);
    problem.surface_D.push_back(x);
    problem.surface_force.push_back(force);
  }
};

struct BlockSolve {
  dm::GridNewtonOutcome outcome;
  double residual_of_all = 0.0;  // |dPi/dC| / load over every unknown, held ones included
};

// Solves from rest and measures the residual itself, from the energy's gradient in every active
// node's coefficients: not the solver's `residual`, which leaves held unknowns out.
BlockSolve solveBlock(const SqueezedBlock& block, const dm::GridNewtonConfig& base) {
  demnerf::core::Material params;
  params.youngs_modulus = 5e5;
  params.poisson_ratio = 0.4;
  const auto material = dm::makeMaterial(params);
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(block.grid.nodeCount(), 3);
  dm::GridNewtonConfig config = base;
  config.threads = 1;
  BlockSolve solve;
  solve.outcome = dm::minimiseGridField(block.problem, *material, block.grid, C, config);
  dm::GridFieldEnergy energy(block.problem, *material, block.grid, 1);
  const auto& active = energy.activeNodes();
  Eigen::VectorXd c(energy.unknowns());
  for (std::size_t l = 0; l < active.size(); ++l) c.segment<3>(3 * l) = C.row(active[l]).transpose();
  // The solver's measure of the load: the external forces, or the start's gradient if larger.
  const double load = std::max(energy.externalNorm(), energy.gradient(Eigen::VectorXd::Zero(c.size())).norm());
  solve.residual_of_all = energy.gradient(c).norm() / load;
  return solve;
}

}  // namespace

TEST(GridNewtonWeakUnknowns, AHoldOnlyTheStartNeededIsReleasedToTheFreeEquilibrium) {
  const SqueezedBlock block(30.0, 2e-4);
  const dm::GridNewtonConfig defaults;
  const BlockSolve released = solveBlock(block, defaults);
  dm::GridNewtonConfig never_held;  // the free equilibrium's reference: nothing is ever held
  never_held.weak_stiffness = 0.0;
  const BlockSolve free = solveBlock(block, never_held);
  dm::GridNewtonConfig kept;
  kept.release_held = false;
  const BlockSolve held = solveBlock(block, kept);
  const auto& r = released.outcome;
  std::cout << std::setprecision(12) << "released: " << r.energy << " J, " << r.iterations << " its, rung "
            << r.hold_rung << ", " << r.released << " released, residual of all " << released.residual_of_all
            << "; never held " << free.outcome.energy << " J, " << free.outcome.iterations << " its; kept: "
            << held.outcome.energy << " J, " << held.outcome.held << " held, held residual "
            << held.outcome.held_residual << "\n";
  // The hold fired and was let go: nothing is held at the answer. (Rung 1 held the one outer
  // function whose cover is below 1e-6 of the mean, which left the Hessian singular; rung 2 held 8
  // of the 9, all but the one the four points cover best.)
  ASSERT_TRUE(r.converged) << "residual " << r.residual << " after " << r.iterations;
  EXPECT_EQ(r.hold_rung, 2);
  EXPECT_GT(r.released, 0);
  EXPECT_EQ(r.held, 0);
  EXPECT_EQ(r.held_residual, 0.0);
  // The answer is the free equilibrium: every unknown in balance, the held ones included, and the
  // energy of the Newton that never held anything (measured 3e-11 apart; the held answer is 2.7e-4 off).
  EXPECT_LE(released.residual_of_all, defaults.residual_tolerance);
  ASSERT_TRUE(free.outcome.converged);
  EXPECT_EQ(free.outcome.held, 0);
  EXPECT_NEAR(r.energy, free.outcome.energy, 1e-9 * std::abs(free.outcome.energy));
  // Kept held, the same unknowns stay out of balance: the solver's residual leaves them out, the
  // held residual and the residual of all unknowns do not, and the energy is higher.
  ASSERT_TRUE(held.outcome.converged);
  EXPECT_EQ(held.outcome.held, r.released);
  EXPECT_EQ(held.outcome.released, 0);
  EXPECT_GT(held.outcome.held_residual, 10 * defaults.residual_tolerance);
  EXPECT_GT(held.residual_of_all, 10 * defaults.residual_tolerance);
  EXPECT_GT(held.outcome.energy - free.outcome.energy, 1e-5 * std::abs(free.outcome.energy));
}
