#include "demnerf/mechanics/dirichlet_lift.hpp"

#include <cmath>

namespace demnerf::mechanics {
namespace {

// g and D of one point (no gradients).
void liftAt(const core::Scenario& scenario, const Eigen::Vector3d& x, double length, Eigen::Vector3d& g,
            Eigen::Vector3d& D) {
  for (int c = 0; c < 3; ++c) {
    std::vector<double> d;
    std::vector<double> v;
    for (const core::Fixture& f : scenario.fixtures)
      if (f.constrained(c)) {
        d.push_back(regionDistance(f.region, x) / length);
        v.push_back(f.displacement(c));
      }
    D(c) = 1.0;
    g(c) = 0.0;
    if (d.empty()) continue;
    for (double dk : d) D(c) *= dk;
    // Transfinite blend: weight of fixture k is the product of the distances to the others, so
    // g equals v_k wherever d_k = 0.
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) {
      double w = 1.0;
      for (std::size_t j = 0; j < d.size(); ++j)
        if (j != k) w *= d[j];
      num += w * v[k];
      den += w;
    }
    if (den > 0.0) {
      g(c) = num / den;
    } else {  // inside two fixtures at once: the last one wins, as in resolveFixtures
      for (std::size_t k = 0; k < d.size(); ++k)
        if (d[k] == 0.0) g(c) = v[k];
    }
  }
}

}  // namespace

double regionDistance(const core::Region& region, const Eigen::Vector3d& x) {
  switch (region.type) {
    case core::Region::Type::kBox:
      return ((x - region.center).cwiseAbs() - 0.5 * region.size).cwiseMax(0.0).norm();
    case core::Region::Type::kSphere:
      return std::max(0.0, (x - region.center).norm() - region.radius);
    case core::Region::Type::kHalfspace:
      return std::max(0.0, (x - region.center).dot(region.normal.normalized()));
  }
  return 0.0;
}

DirichletLift dirichletLift(const core::Scenario& scenario, const std::vector<Eigen::Vector3d>& points, double length) {
  DirichletLift lift;
  const std::size_t n = points.size();
  lift.g.resize(n);
  lift.D.resize(n);
  lift.grad_g.resize(n);
  lift.grad_D.resize(n);
  // Central differences: the distance functions are only piecewise smooth, and this averages
  // their one-sided slopes at kinks, which is what the network sees anyway.
  const double h = 1e-6 * length;
  for (std::size_t i = 0; i < n; ++i) {
    liftAt(scenario, points[i], length, lift.g[i], lift.D[i]);
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d gp, gm, Dp, Dm, xp = points[i], xm = points[i];
      xp(k) += h;
      xm(k) -= h;
      liftAt(scenario, xp, length, gp, Dp);
      liftAt(scenario, xm, length, gm, Dm);
      lift.grad_g[i].col(k) = (gp - gm) / (2 * h);
      lift.grad_D[i].col(k) = (Dp - Dm) / (2 * h);
    }
  }
  return lift;
}

}  // namespace demnerf::mechanics
