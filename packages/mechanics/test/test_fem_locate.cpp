// FemSolver::interpolate's point location (a shell search of its cell grid) answers as a search of
// every element does, inside the mesh and just outside it.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/reference_problems.hpp"

namespace dm = demnerf::mechanics;
using Eigen::Vector3d;

namespace {

// The displacement at x in the element whose smallest barycentric coordinate is largest (the
// containing one, or the nearest's polynomial outside), searched over all elements.
Vector3d bruteForce(const dm::TetMesh& mesh, const std::vector<Vector3d>& u, const Vector3d& x) {
  double best_score = -std::numeric_limits<double>::infinity();
  Vector3d best = Vector3d::Zero();
  for (const auto& e : mesh.elements) {
    const Eigen::Vector4d L = dm::barycentric({mesh.nodes[e[0]], mesh.nodes[e[1]], mesh.nodes[e[2]], mesh.nodes[e[3]]}, x);
    if (L.minCoeff() <= best_score) continue;
    best_score = L.minCoeff();
    const Eigen::VectorXd N = dm::tetShape(mesh.order, L);
    best.setZero();
    for (int a = 0; a < N.size(); ++a) best += N(a) * u[e[a]];
  }
  return best;
}

TEST(FemLocate, ShellSearchMatchesSearchingEveryElement) {
  // Cook's membrane bends: a quadratic field that differs from element to element, so a wrong
  // element's polynomial would show.
  dm::FemSolver fem(dm::cookMembraneMesh(6, 2), dm::cookMembraneScenario());
  const dm::FemResult& r = fem.solve();
  const dm::TetMesh& mesh = fem.mesh();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Vector3d> points;
  for (int i = 0; i < 400; ++i) {
    // A point of the membrane (x, its edges' y at x, z through the 1 mm), the last quarter pushed
    // up to 0.4 mm outside it through the top, bottom or a z face.
    const double x = 0.048 * unit(rng), lower = 0.044 * x / 0.048, upper = 0.044 + 0.016 * x / 0.048;
    Vector3d p(x, lower + (upper - lower) * unit(rng), 0.001 * unit(rng));
    if (i % 4 == 3) p += Vector3d(0, unit(rng) < 0.5 ? -4e-4 : 0.0, 4e-4 * (unit(rng) - 0.5));
    points.push_back(p);
  }
  const dm::PointField at = fem.interpolate(points);
  double scale = 0;
  for (const Vector3d& u : r.displacement) scale = std::max(scale, u.norm());
  ASSERT_GT(scale, 1e-3);
  for (std::size_t i = 0; i < points.size(); ++i)
    EXPECT_LT((at.displacement[i] - bruteForce(mesh, r.displacement, points[i])).norm(), 1e-9 * scale)
        << "point " << i << ": " << points[i].transpose();
}

}  // namespace
