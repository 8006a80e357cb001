// Extended B-splines: which nodes stay unknowns, and that the extrapolation continues the field
// inside as the same polynomial (the property the method rests on).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/bspline_extension.hpp"

namespace demnerf::mechanics {
namespace {

struct Case {
  BsplineGrid grid;
  std::vector<long> nodes;
  std::vector<double> fill;
};

// A 6 x 5 x 4 cell grid whose cells with i >= 2 are inside (fill 1) and the others cut (fill 0.2).
Case halfFilledGrid(int degree) {
  Case c{BsplineGrid(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.6, 0.5, 0.4), 0.1, degree), {}, {}};
  const Eigen::Vector3i cells = c.grid.cells();
  for (int k = 0; k < cells(2); ++k)
    for (int j = 0; j < cells(1); ++j)
      for (int i = 0; i < cells(0); ++i) c.fill.push_back(i >= 2 ? 1.0 : 0.2);
  for (long a = 0; a < c.grid.nodeCount(); ++a) c.nodes.push_back(a);
  return c;
}

Eigen::Vector3i nodeIndex(const BsplineGrid& grid, long a) {
  const Eigen::Vector3i nn = grid.cells() + Eigen::Vector3i::Constant(grid.degree());
  return {static_cast<int>(a % nn(0)), static_cast<int>((a / nn(0)) % nn(1)), static_cast<int>(a / (nn(0) * nn(1)))};
}

TEST(BsplineExtension, KeepsExactlyTheNodesThatTouchAFilledCell) {
  for (int degree = 1; degree <= 3; ++degree) {
    const Case c = halfFilledGrid(degree);
    const BsplineExtension ext = extendOuterNodes(c.grid, c.nodes, c.fill);
    // Node index v touches cells v - degree .. v: a filled one when v >= 2 along x.
    long expected = 0;
    for (long a : c.nodes) expected += nodeIndex(c.grid, a)(0) >= 2;
    EXPECT_EQ(static_cast<long>(ext.kept.size()), expected) << "degree " << degree;
    for (long l : ext.kept) EXPECT_GE(nodeIndex(c.grid, c.nodes[l])(0), 2);
    EXPECT_EQ(ext.map.rows(), static_cast<long>(c.nodes.size()));
    EXPECT_EQ(ext.map.cols(), static_cast<long>(ext.kept.size()));
  }
}

// Coefficients that are a polynomial of degree <= p per axis in the node index describe a
// polynomial field; the extension must give every extrapolated node that polynomial's value.
TEST(BsplineExtension, ContinuesAPolynomialFieldExactly) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coefficient(-1.0, 1.0);
  for (int degree = 1; degree <= 3; ++degree) {
    const Case c = halfFilledGrid(degree);
    double a[4][4][4];
    for (auto& plane : a)
      for (auto& row : plane)
        for (double& v : row) v = coefficient(rng);
    const auto polynomial = [&](const Eigen::Vector3i& v) {
      double sum = 0.0;
      for (int i = 0; i <= degree; ++i)
        for (int j = 0; j <= degree; ++j)
          for (int k = 0; k <= degree; ++k) sum += a[i][j][k] * std::pow(v(0), i) * std::pow(v(1), j) * std::pow(v(2), k);
      return sum;
    };
    const BsplineExtension ext = extendOuterNodes(c.grid, c.nodes, c.fill);
    Eigen::VectorXd kept(ext.kept.size());
    for (std::size_t k = 0; k < ext.kept.size(); ++k) kept(k) = polynomial(nodeIndex(c.grid, c.nodes[ext.kept[k]]));
    const Eigen::VectorXd all = ext.map * kept;
    for (std::size_t l = 0; l < c.nodes.size(); ++l) {
      const double want = polynomial(nodeIndex(c.grid, c.nodes[l]));
      EXPECT_NEAR(all(l), want, 1e-9 * (1.0 + std::abs(want))) << "degree " << degree << ", node " << l;
    }
  }
}

TEST(BsplineExtension, RejectsAFillListOfTheWrongSize) {
  const Case c = halfFilledGrid(2);
  EXPECT_THROW(extendOuterNodes(c.grid, c.nodes, std::vector<double>(3, 1.0)), core::Error);
}

}  // namespace
}  // namespace demnerf::mechanics
