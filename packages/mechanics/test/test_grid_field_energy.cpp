// The feature grid's energy assembles its Hessian cell by cell directly in the extended basis's
// unknowns, on several threads. These tests hold it to the definition: E^T H E of the Hessian in
// every active node's coefficients, the same on one thread and on three, and a gradient that
// finite differences of the energy confirm.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <random>

#include "../src/grid_field_energy.hpp"
#include "demnerf/mechanics/bspline_extension.hpp"

namespace demnerf::mechanics {
namespace {

// Points that fill a slanted slab of a 6 x 5 x 4 cell grid, so that some cells are cut (their nodes
// extrapolated) and some full; the distance factor varies per component like a fixture's.
struct SlabProblem {
  BsplineGrid grid{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.6, 0.5, 0.4), 0.1, 2};
  GridFieldProblem problem;
  std::vector<double> cell_fill;

  SlabProblem() {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    cell_fill.assign(static_cast<std::size_t>(grid.cells().prod()), 0.0);
    // The slab's volume (0.39 x 0.5 x 0.4) shared by the points, so that cells inside it fill.
    const long count = 8000;
    const double volume = 0.078 / count;
    while (static_cast<long>(problem.points.size()) < count) {
      const Eigen::Vector3d x(0.6 * unit(rng), 0.5 * unit(rng), 0.4 * unit(rng));
      if (x(0) + 0.3 * x(2) > 0.45) continue;  // the slab's slanted face cuts cells
      problem.points.push_back(x);
      problem.volume.push_back(volume);
      problem.body.push_back(Eigen::Vector3d(0.0, 0.0, -50.0) * volume);
      problem.offset.push_back(Eigen::Vector3d(0.001 * x(1), 0.0, 0.0));
      Eigen::Matrix3d grad_offset = Eigen::Matrix3d::Zero();
      grad_offset(0, 1) = 0.001;
      problem.grad_offset.push_back(grad_offset);
      problem.D.push_back(Eigen::Vector3d(x(0), x(0) * x(0), 1.0));  // u_x, u_y vanish at x = 0
      Eigen::Matrix3d grad_D = Eigen::Matrix3d::Zero();
      grad_D(0, 0) = 1.0;
      grad_D(1, 0) = 2.0 * x(0);
      problem.grad_D.push_back(grad_D);
      cell_fill[grid.cellIndex(x)] += volume / 1e-3;
    }
  }
};

Eigen::SparseMatrix<double> expandComponents(const Eigen::SparseMatrix<double>& node_map) {
  std::vector<Eigen::Triplet<double>> entries;
  for (int k = 0; k < node_map.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(node_map, k); it; ++it)
      for (int i = 0; i < 3; ++i)
        entries.emplace_back(3 * static_cast<int>(it.row()) + i, 3 * static_cast<int>(it.col()) + i, it.value());
  Eigen::SparseMatrix<double> map(3 * node_map.rows(), 3 * node_map.cols());
  map.setFromTriplets(entries.begin(), entries.end());
  return map;
}

// A small random state (metres): well inside the admissible set, far from the undeformed one.
Eigen::VectorXd randomCoefficients(long count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> small(0.0, 1e-3);
  Eigen::VectorXd c(count);
  for (Eigen::Index k = 0; k < c.size(); ++k) c(k) = small(rng);
  return c;
}

Eigen::MatrixXd symmetric(const Eigen::SparseMatrix<double>& lower) {
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  return Eigen::MatrixXd(full);
}

TEST(GridFieldEnergy, ReducedHessianIsTheProjectionOfTheFullOneOnAnyThreadCount) {
  const SlabProblem slab;
  const NeoHookean material(1e4, 2e4);
  GridFieldEnergy full_energy(slab.problem, material, slab.grid, 1);
  const std::vector<long>& active = full_energy.activeNodes();
  const BsplineExtension ext = extendOuterNodes(slab.grid, active, slab.cell_fill, 0.75);
  ASSERT_LT(ext.kept.size(), active.size()) << "the slab must have extrapolated nodes";
  full_energy.setUnknownMap({});

  const Eigen::VectorXd c = randomCoefficients(full_energy.unknowns(), 5);
  Eigen::VectorXd g_full;
  Eigen::SparseMatrix<double> h_full;
  full_energy.derivatives(c, g_full, h_full);
  const Eigen::SparseMatrix<double> E = expandComponents(ext.map);
  const Eigen::MatrixXd expected = Eigen::MatrixXd(E.transpose()) * symmetric(h_full) * Eigen::MatrixXd(E);

  for (int threads : {1, 3}) {
    GridFieldEnergy energy(slab.problem, material, slab.grid, threads);
    energy.setUnknownMap(ext.map);
    Eigen::VectorXd g;
    Eigen::SparseMatrix<double> h;
    energy.derivatives(c, g, h);
    ASSERT_EQ(h.rows(), expected.rows());
    EXPECT_LT((symmetric(h) - expected).norm(), 1e-10 * expected.norm()) << threads << " threads";
    EXPECT_LT((g - g_full).norm(), 1e-12 * g_full.norm()) << threads << " threads";
    EXPECT_NEAR(energy.energy(c), full_energy.energy(c), 1e-12 * std::abs(full_energy.energy(c)));
  }
}

TEST(GridFieldEnergy, GradientMatchesFiniteDifferencesOfTheEnergy) {
  const SlabProblem slab;
  const NeoHookean material(1e4, 2e4);
  GridFieldEnergy energy(slab.problem, material, slab.grid, 2);
  energy.setUnknownMap({});
  const Eigen::VectorXd c = randomCoefficients(energy.unknowns(), 9);
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> h;
  energy.derivatives(c, g, h);
  const Eigen::VectorXd direction = g.normalized();
  const double step = 1e-6;
  const double slope = (energy.energy(c + step * direction) - energy.energy(c - step * direction)) / (2 * step);
  EXPECT_NEAR(slope, g.dot(direction), 1e-5 * g.norm());
  // And the Hessian is the gradient's derivative along the same direction.
  Eigen::VectorXd g_plus, g_minus;
  Eigen::SparseMatrix<double> unused;
  energy.derivatives(c + step * direction, g_plus, unused);
  energy.derivatives(c - step * direction, g_minus, unused);
  const Eigen::VectorXd curvature = (g_plus - g_minus) / (2 * step);
  const Eigen::VectorXd hd = h.selfadjointView<Eigen::Lower>() * direction;
  EXPECT_LT((curvature - hd).norm(), 1e-4 * hd.norm());
  // The gradient alone (the MLP-only DEM's equilibrium check) is the same vector, with or without
  // an unknown map, on any thread count.
  for (int threads : {1, 3}) {
    const GridFieldEnergy plain(slab.problem, material, slab.grid, threads);
    EXPECT_LT((plain.gradient(c) - g).norm(), 1e-12 * g.norm()) << threads << " threads";
  }
}

TEST(GridFieldEnergy, DerivativesBeforeTheUnknownMapAreRefused) {
  const SlabProblem slab;
  const NeoHookean material(1e4, 2e4);
  const GridFieldEnergy energy(slab.problem, material, slab.grid, 1);
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> h;
  EXPECT_THROW(energy.derivatives(Eigen::VectorXd::Zero(energy.unknowns()), g, h), std::exception);
}

// The nested solve's fine grid starts from a field moved from a coarser grid, compressed at a few
// cut-cell points (det F ~0.76 on the NeRF T-bar), where the Neo-Hookean tangent is strongly
// indefinite: its first Hessian is then indefinite and costs a failed factorisation and a shift
// (GridNewtonConfig::projected_start). With `projected`, every point's tangent is made positive
// semidefinite, so the Hessian is too; the gradient stays the energy's.
// A slab whose lift u_0 squeezes x by 35 % and shears x-y: det F = 0.65 at every point.
SlabProblem compressedSlab() {
  SlabProblem slab;
  Eigen::Matrix3d grad = Eigen::Matrix3d::Zero();
  grad(0, 0) = -0.35;
  grad(0, 1) = 0.2;
  for (std::size_t p = 0; p < slab.problem.points.size(); ++p) {
    slab.problem.offset[p] = grad * slab.problem.points[p];
    slab.problem.grad_offset[p] = grad;
  }
  return slab;
}

TEST(GridFieldEnergy, ProjectedHessianIsPositiveSemidefiniteWhereTheExactOneIsNot) {
  SlabProblem slab = compressedSlab();
  const NeoHookean material(1e4, 2e4);
  GridFieldEnergy energy(slab.problem, material, slab.grid, 2);
  energy.setUnknownMap(extendOuterNodes(slab.grid, energy.activeNodes(), slab.cell_fill, 0.75).map);
  const Eigen::VectorXd c = randomCoefficients(energy.unknowns(), 7);
  Eigen::VectorXd g_exact, g_projected;
  Eigen::SparseMatrix<double> h_exact, h_projected;
  energy.derivatives(c, g_exact, h_exact);
  energy.derivatives(c, g_projected, h_projected, true);
  const Eigen::VectorXd exact = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric(h_exact)).eigenvalues();
  const Eigen::VectorXd projected =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric(h_projected)).eigenvalues();
  const double scale = exact.cwiseAbs().maxCoeff();
  ASSERT_LT(exact.minCoeff(), -1e-3 * scale) << "the compressed state must make the exact Hessian indefinite";
  EXPECT_GT(projected.minCoeff(), -1e-10 * scale);
  EXPECT_EQ((g_projected - g_exact).norm(), 0.0);
  // Where every tangent is positive definite already (a small random state about rest, stretched
  // so that no plane is compressed) the projection changes nothing.
  SlabProblem mild;
  for (std::size_t p = 0; p < mild.problem.points.size(); ++p) {
    mild.problem.offset[p] = 0.05 * mild.problem.points[p];
    mild.problem.grad_offset[p] = 0.05 * Eigen::Matrix3d::Identity();
  }
  GridFieldEnergy stretched(mild.problem, material, mild.grid, 2);
  stretched.setUnknownMap({});
  const Eigen::VectorXd small = 1e-2 * randomCoefficients(stretched.unknowns(), 11);
  stretched.derivatives(small, g_exact, h_exact);
  stretched.derivatives(small, g_projected, h_projected, true);
  EXPECT_LT(symmetric(h_projected - h_exact).norm(), 1e-12 * symmetric(h_exact).norm());
}

// The Newton from such a start (GridNewtonConfig::projected_start, as the nested solve's fine grid
// runs it: near_minimum, unshifted first) reaches the same minimiser in fewer iterations (5 against
// 7 here) and no more factorisations: the exact first Hessian's unshifted factorisation fails, and
// Lanczos' shift damps the first steps.
TEST(GridFieldEnergy, ProjectedStartReachesTheSameMinimumInFewerIterations) {
  SlabProblem slab = compressedSlab();
  for (std::size_t p = 0; p < slab.problem.points.size(); ++p) {
    // Clamped at x = 0 in every component, so the energy has a minimum under the body force.
    slab.problem.D[p] = Eigen::Vector3d::Constant(slab.problem.points[p](0));
    slab.problem.grad_D[p] = Eigen::Matrix3d::Zero();
    slab.problem.grad_D[p].col(0).setOnes();
  }
  const NeoHookean material(1e4, 2e4);
  GridNewtonOutcome outcome[2];
  for (int projected : {0, 1}) {
    GridNewtonConfig config;
    config.near_minimum = true;
    config.projected_start = projected;
    config.extension_fill = 0.25;
    config.threads = 2;
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(slab.grid.nodeCount(), 3);
    outcome[projected] = minimiseGridField(slab.problem, material, slab.grid, C, config);
    EXPECT_TRUE(outcome[projected].converged) << projected;
  }
  // Both stop at a residual of 1e-6 of the load: the energies agree to about its square.
  EXPECT_NEAR(outcome[1].energy, outcome[0].energy, 1e-7 * std::abs(outcome[0].energy));
  EXPECT_LT(outcome[1].iterations, outcome[0].iterations);
  EXPECT_LE(outcome[1].factorisations, outcome[0].factorisations);
}

}  // namespace
}  // namespace demnerf::mechanics
