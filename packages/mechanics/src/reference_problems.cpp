#include "demnerf/mechanics/reference_problems.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

core::Region box(const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  core::Region r;
  r.type = core::Region::Type::kBox;
  r.center = center;
  r.size = size;
  return r;
}

// Root of a monotone function on [lo, hi] by bisection (robust; these are scalar closed forms).
template <typename Fn>
double bisect(Fn f, double lo, double hi) {
  double flo = f(lo);
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi), fm = f(mid);
    if ((fm > 0) == (flo > 0)) {
      lo = mid;
      flo = fm;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

}  // namespace

core::Scenario cookMembraneScenario() {
  core::Scenario s;
  s.name = "cook_membrane";
  s.material.model = "neo_hookean_decoupled";
  const double mu = 422.5e3, nu = 0.3;
  s.material.youngs_modulus = 2.0 * mu * (1.0 + nu);
  s.material.poisson_ratio = nu;
  core::Fixture clamp;
  clamp.name = "left_edge";
  clamp.region = box(Eigen::Vector3d(0, 0.022, 0.0005), Eigen::Vector3d(1e-6, 0.05, 0.01));
  core::Fixture plane;
  plane.name = "plane_strain";
  plane.region = box(Eigen::Vector3d(0.024, 0.03, 0.0005), Eigen::Vector3d(0.1, 0.1, 0.01));
  plane.constrained = Eigen::Vector3i(0, 0, 1);
  s.fixtures = {clamp, plane};
  core::Load shear;
  shear.name = "right_edge";
  shear.region = box(Eigen::Vector3d(0.048, 0.052, 0.0005), Eigen::Vector3d(1e-6, 0.02, 0.01));
  shear.force = Eigen::Vector3d(0, 1.0, 0);
  s.loads = {shear};
  s.load_steps = 10;
  return s;
}

TetMesh cookMembraneMesh(int cells, int order) {
  return structuredMesh(Eigen::Vector3i(cells, cells, 1), order, [](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    const Eigen::Vector2d c0(0, 0), c1(0.048, 0.044), c2(0.048, 0.060), c3(0, 0.044);
    const double s = p.x(), t = p.y();
    const Eigen::Vector2d xy = (1 - s) * (1 - t) * c0 + s * (1 - t) * c1 + s * t * c2 + (1 - s) * t * c3;
    return Eigen::Vector3d(xy.x(), xy.y(), 0.001 * p.z());
  });
}

Eigen::Vector3d cookMembraneTip() { return Eigen::Vector3d(0.048, 0.052, 0.0005); }

double uniaxialLateralStretch(const HyperelasticMaterial& material, double a) {
  auto p22 = [&](double b) { return material.stress(Eigen::Vector3d(a, b, b).asDiagonal())(1, 1); };
  return bisect(p22, 0.05, 5.0);
}

double uniaxialStretchForStress(const HyperelasticMaterial& material, double p11, double* lateral) {
  auto residual = [&](double a) {
    const double b = uniaxialLateralStretch(material, a);
    return material.stress(Eigen::Vector3d(a, b, b).asDiagonal())(0, 0) - p11;
  };
  const double a = bisect(residual, 0.2, 5.0);
  if (lateral) *lateral = uniaxialLateralStretch(material, a);
  return a;
}

core::Scenario uniaxialTractionScenario(double p11, const std::string& model) {
  auto plane = [](const Eigen::Vector3d& center, int axis) {
    core::Region r;
    r.type = core::Region::Type::kBox;
    r.center = center;
    r.size = Eigen::Vector3d(2, 2, 2);
    r.size(axis) = 1e-6;  // a thin slab selects the face's particles and nodes
    return r;
  };
  core::Scenario s;
  s.name = "uniaxial";
  s.material.model = model;
  s.material.youngs_modulus = 1e6;
  s.material.poisson_ratio = 0.3;
  for (int axis = 0; axis < 3; ++axis) {
    core::Fixture f;
    f.name = std::string("roller_") + "xyz"[axis];
    Eigen::Vector3d c(0.5, 0.5, 0.5);
    c(axis) = 0.0;
    f.region = plane(c, axis);
    f.constrained = Eigen::Vector3i::Zero();
    f.constrained(axis) = 1;
    s.fixtures.push_back(f);
  }
  core::Load pull;
  pull.name = "pull";
  pull.region = plane(Eigen::Vector3d(1, 0.5, 0.5), 0);
  pull.force = Eigen::Vector3d(p11, 0, 0);
  s.loads = {pull};
  return s;
}

}  // namespace demnerf::mechanics
