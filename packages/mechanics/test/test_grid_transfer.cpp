// The nested grid solve's transfer of a coarse grid's field onto the fine grid
// (src/grid_transfer.hpp): exact where the fine grid holds the field, the least-squares best where
// it does not; and the coarse field's continuation onto nodes its own points did not see.
#include <gtest/gtest.h>

#include <random>

#include "../src/grid_transfer.hpp"
#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

// Points with weights in the part x < 0.5 of the box [0, 0.8] x [0, 0.6] x [0, 0.4], so that some
// nodes of either grid are seen by no point.
struct Points {
  std::vector<Eigen::Vector3d> x;
  std::vector<double> w;
  explicit Points(int count, unsigned seed = 5) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < count; ++i) {
      x.emplace_back(0.5 * unit(rng), 0.6 * unit(rng), 0.4 * unit(rng));
      w.push_back(0.5 + unit(rng));
    }
  }
};

Eigen::Vector3d field(const BsplineGrid& grid, const Eigen::MatrixXd& C, const Eigen::Vector3d& x) {
  std::vector<long> nodes(grid.supportSize());
  std::vector<double> N(grid.supportSize());
  std::vector<Eigen::Vector3d> dN(grid.supportSize());
  grid.evaluate(x, nodes.data(), N.data(), dN.data());
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  for (int s = 0; s < grid.supportSize(); ++s) u += N[s] * C.row(nodes[s]).transpose();
  return u;
}

TEST(GridTransfer, IsExactForACoarseFieldOnHalvedCells) {
  // Aligned grids, the fine one with half the cell: every coarse quadratic B-spline is a sum of
  // fine ones (knot insertion), so the least-squares fit must reproduce the field to rounding.
  const Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi(0.8, 0.6, 0.4);
  const BsplineGrid coarse(lo, hi, 0.2, 2), fine(lo, hi, 0.1, 2);
  ASSERT_TRUE(coarse.origin().isZero() && fine.origin().isZero());
  std::mt19937 rng(2);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd C(coarse.nodeCount(), 3);
  for (long i = 0; i < C.size(); ++i) C(i) = normal(rng);
  const Points points(6000);
  const Eigen::MatrixXd moved = transferGridField(coarse, C, fine, points.x, points.w);
  const Points probes(500, 9);
  double worst = 0.0, scale = 0.0;
  for (const Eigen::Vector3d& x : probes.x) {
    worst = std::max(worst, (field(fine, moved, x) - field(coarse, C, x)).norm());
    scale = std::max(scale, field(coarse, C, x).norm());
  }
  EXPECT_GT(scale, 0.5);
  EXPECT_LT(worst, 1e-8 * scale);
  // Nodes whose support no point reaches (x > 0.7: cells right of 0.5 plus the quadratic's reach)
  // are left at zero.
  EXPECT_EQ(moved.row(fine.nodeCount() - 1).norm(), 0.0);
}

TEST(GridTransfer, IsTheLeastSquaresBestOnAnUnrelatedGrid) {
  // Cells of 0.13 against 0.2: the coarse field is not in the target's span. The fit's residual must
  // then be orthogonal to every target function the points see (the normal equations), and the fit
  // closer than the target grid's zero field by far.
  const Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi(0.8, 0.6, 0.4);
  const BsplineGrid coarse(lo, hi, 0.2, 2), other(lo, hi, 0.13, 2);
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd C(coarse.nodeCount(), 3);
  for (long i = 0; i < C.size(); ++i) C(i) = normal(rng);
  const Points points(6000);
  const Eigen::MatrixXd moved = transferGridField(coarse, C, other, points.x, points.w);
  Eigen::MatrixXd normal_residual = Eigen::MatrixXd::Zero(other.nodeCount(), 3);
  double misfit = 0.0, total = 0.0;
  std::vector<long> nodes(other.supportSize());
  std::vector<double> N(other.supportSize());
  std::vector<Eigen::Vector3d> dN(other.supportSize());
  for (std::size_t q = 0; q < points.x.size(); ++q) {
    const Eigen::Vector3d r = field(other, moved, points.x[q]) - field(coarse, C, points.x[q]);
    misfit += points.w[q] * r.squaredNorm();
    total += points.w[q] * field(coarse, C, points.x[q]).squaredNorm();
    other.evaluate(points.x[q], nodes.data(), N.data(), dN.data());
    for (int s = 0; s < other.supportSize(); ++s) normal_residual.row(nodes[s]) += points.w[q] * N[s] * r.transpose();
  }
  EXPECT_LT(normal_residual.cwiseAbs().maxCoeff(), 1e-8 * std::sqrt(total));
  EXPECT_LT(misfit, 0.05 * total);
}

TEST(GridTransfer, ContinuesAFieldOntoNodesItsPointsDidNotSee) {
  // A grid's points fill x < 0.5; its Newton solved the nodes they see (here a quadratic polynomial
  // of the node index, which the quadratic extension reproduces exactly) and left the others at 0.
  // Targets in the cells beyond (0.5 <= x < 0.7, the fine grid's extra body in the nested solve)
  // must then read the polynomial's field, not one that falls to zero across a cell.
  const BsplineGrid grid(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.8, 0.6, 0.4), 0.1, 2);
  std::vector<Eigen::Vector3d> points, targets;
  std::vector<double> weights;
  const double h = 0.025;
  for (double x = 0.5 * h; x < 0.7; x += h)
    for (double y = 0.5 * h; y < 0.6; y += h)
      for (double z = 0.5 * h; z < 0.4; z += h) (x < 0.5 ? points : targets).emplace_back(x, y, z);
  weights.assign(points.size(), h * h * h);
  const Eigen::Vector3i nn = grid.cells() + Eigen::Vector3i::Constant(2);
  const auto polynomial = [&](long a) {
    const Eigen::Vector3d v(a % nn(0), (a / nn(0)) % nn(1), a / (nn(0) * nn(1)));
    return Eigen::Vector3d(0.3 * v(0) - 0.02 * v(0) * v(0) + 0.1 * v(1) * v(2), 0.05 * v(0) * v(1) - 0.2 * v(2),
                           0.01 * v(0) * v(2) + 0.04 * v(1) * v(1));
  };
  Eigen::MatrixXd exact(grid.nodeCount(), 3);
  for (long a = 0; a < grid.nodeCount(); ++a) exact.row(a) = polynomial(a).transpose();
  // The solved nodes: those of the cells that hold a point.
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(grid.nodeCount(), 3);
  std::vector<long> nodes(grid.supportSize());
  std::vector<double> N(grid.supportSize());
  std::vector<Eigen::Vector3d> dN(grid.supportSize());
  for (const Eigen::Vector3d& x : points) {
    grid.evaluate(x, nodes.data(), N.data(), dN.data());
    for (long a : nodes) C.row(a) = exact.row(a);
  }
  const Eigen::MatrixXd solved = C;
  double before = 0.0;
  for (const Eigen::Vector3d& x : targets)
    before = std::max(before, (field(grid, C, x) - field(grid, exact, x)).norm());
  EXPECT_GT(before, 0.1);  // the zeros are far off: the test would fail without the continuation
  const long continued = continueUnseenNodes(grid, C, points, weights, targets, 0.25);
  EXPECT_GT(continued, 0);
  double after = 0.0;
  for (const Eigen::Vector3d& x : targets)
    after = std::max(after, (field(grid, C, x) - field(grid, exact, x)).norm());
  EXPECT_LT(after, 1e-9);
  // The solved nodes are left as they were, and nodes no target reaches (beyond x = 0.9) too.
  for (long a = 0; a < grid.nodeCount(); ++a)
    if (solved.row(a).norm() > 0) EXPECT_EQ((C.row(a) - solved.row(a)).norm(), 0.0) << "node " << a;
  EXPECT_EQ(C.row(grid.nodeCount() - 1).norm(), 0.0);
  // Nothing to continue when the targets lie where the points are.
  Eigen::MatrixXd again = solved;
  EXPECT_EQ(continueUnseenNodes(grid, again, points, weights, points, 0.25), 0);
  EXPECT_EQ((again - solved).norm(), 0.0);
}

TEST(GridTransfer, RefusesMismatchedSizes) {
  const BsplineGrid grid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(), 0.5, 2);
  const Points points(10);
  EXPECT_THROW(transferGridField(grid, Eigen::MatrixXd::Zero(3, 3), grid, points.x, points.w), core::Error);
  EXPECT_THROW(transferGridField(grid, Eigen::MatrixXd::Zero(grid.nodeCount(), 3), grid, points.x, {1.0}), core::Error);
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(3, 3);
  EXPECT_THROW(continueUnseenNodes(grid, C, points.x, points.w, points.x, 0.25), core::Error);
}

}  // namespace
}  // namespace demnerf::mechanics
