#include "demnerf/mechanics/dirichlet_lift.hpp"

#include <algorithm>
#include <cmath>

#include "demnerf/mechanics/held_face.hpp"

namespace demnerf::mechanics {
namespace {

// Distance to a region and its gradient (0 inside, where the distance is flat). The gradient of
// a Euclidean distance has unit length wherever it is non-zero, so D's slope is bounded.
double regionDistanceAndGradient(const core::Region& region, const Eigen::Vector3d& x, Eigen::Vector3d& grad) {
  grad.setZero();
  switch (region.type) {
    case core::Region::Type::kBox: {
      const Eigen::Vector3d rel = x - region.center;
      const Eigen::Vector3d outside = (rel.cwiseAbs() - 0.5 * region.size).cwiseMax(0.0);
      const double d = outside.norm();
      if (d > 0.0)
        for (int k = 0; k < 3; ++k) grad(k) = (rel(k) < 0 ? -1.0 : 1.0) * outside(k) / d;
      return d;
    }
    case core::Region::Type::kSphere: {
      const Eigen::Vector3d rel = x - region.center;
      const double r = rel.norm();
      if (r <= region.radius) return 0.0;
      grad = rel / r;
      return r - region.radius;
    }
    case core::Region::Type::kHalfspace: {
      const Eigen::Vector3d n = region.normal.normalized();
      const double d = (x - region.center).dot(n);
      if (d <= 0.0) return 0.0;
      grad = n;
      return d;
    }
  }
  return 0.0;
}

}  // namespace

double regionDistance(const core::Region& region, const Eigen::Vector3d& x) {
  return std::max(0.0, regionSignedDistance(region, x));
}

double regionSignedDistance(const core::Region& region, const Eigen::Vector3d& x) {
  switch (region.type) {
    case core::Region::Type::kBox: {
      const Eigen::Vector3d q = (x - region.center).cwiseAbs() - 0.5 * region.size;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case core::Region::Type::kSphere: return (x - region.center).norm() - region.radius;
    case core::Region::Type::kHalfspace: return (x - region.center).dot(region.normal.normalized());
  }
  return 0.0;
}

void dirichletLiftAt(const core::Scenario& scenario, const Eigen::Vector3d& x, double length, Eigen::Vector3d& g,
                     Eigen::Matrix3d& grad_g, Eigen::Vector3d& D, Eigen::Matrix3d& grad_D,
                     const std::vector<HeldFace>* held, bool signed_faces) {
  // Distances to every fixture once; components pick the fixtures that constrain them.
  constexpr int kMaxFixtures = 16;
  const int nf = static_cast<int>(scenario.fixtures.size());
  double dist_small[kMaxFixtures];
  Eigen::Vector3d grad_small[kMaxFixtures];
  std::vector<double> dist_big;
  std::vector<Eigen::Vector3d> grad_big;
  double* dist = dist_small;
  Eigen::Vector3d* grad = grad_small;
  if (nf > kMaxFixtures) {
    dist_big.resize(nf);
    grad_big.resize(nf);
    dist = dist_big.data();
    grad = grad_big.data();
  }
  for (int f = 0; f < nf; ++f) {
    const bool face = held && f < static_cast<int>(held->size()) && (*held)[f].valid;
    dist[f] = (face ? heldFaceDistance((*held)[f], x, grad[f], signed_faces)
                    : regionDistanceAndGradient(scenario.fixtures[f].region, x, grad[f])) / length;
    grad[f] /= length;
  }
  for (int c = 0; c < 3; ++c) {
    // D_c = prod_k d_k over the fixtures constraining c; transfinite lift
    // g_c = sum_k w_k v_k / sum_k w_k with w_k = prod_{j != k} d_j, so g_c = v_k wherever d_k = 0.
    double Dc = 1.0, num = 0.0, den = 0.0;
    Eigen::Vector3d gD = Eigen::Vector3d::Zero(), gnum = Eigen::Vector3d::Zero(), gden = Eigen::Vector3d::Zero();
    int count = 0;
    double inside_value = 0.0;
    bool inside = false;
    for (int k = 0; k < nf; ++k) {
      const core::Fixture& fk = scenario.fixtures[k];
      if (!fk.constrained(c)) continue;
      ++count;
      gD = gD * dist[k] + Dc * grad[k];
      Dc *= dist[k];
      double w = 1.0;
      Eigen::Vector3d gw = Eigen::Vector3d::Zero();
      for (int j = 0; j < nf; ++j) {
        if (j == k || !scenario.fixtures[j].constrained(c)) continue;
        gw = gw * dist[j] + w * grad[j];
        w *= dist[j];
      }
      num += w * fk.displacement(c);
      gnum += gw * fk.displacement(c);
      den += w;
      gden += gw;
      if (dist[k] == 0.0) {  // inside two fixtures at once: the last one wins, as in resolveFixtures
        inside = true;
        inside_value = fk.displacement(c);
      }
    }
    D(c) = count ? Dc : 1.0;
    grad_D.row(c) = count ? Eigen::RowVector3d(gD.transpose()) : Eigen::RowVector3d::Zero();
    g(c) = 0.0;
    grad_g.row(c).setZero();
    if (!count) continue;
    if (den > 0.0) {
      g(c) = num / den;
      grad_g.row(c) = ((gnum * den - num * gden) / (den * den)).transpose();
    } else if (inside) {
      g(c) = inside_value;
    }
  }
}

DirichletLift dirichletLift(const core::Scenario& scenario, const std::vector<Eigen::Vector3d>& points, double length,
                            const std::vector<HeldFace>* held, bool signed_faces) {
  DirichletLift lift;
  const std::size_t n = points.size();
  lift.g.resize(n);
  lift.D.resize(n);
  lift.grad_g.resize(n);
  lift.grad_D.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    dirichletLiftAt(scenario, points[i], length, lift.g[i], lift.grad_g[i], lift.D[i], lift.grad_D[i], held,
                    signed_faces);
  return lift;
}

}  // namespace demnerf::mechanics
