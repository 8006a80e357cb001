#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/render/displacement_interpolator.hpp"
#include "demnerf/render/scene_geometry.hpp"

namespace demnerf::render {
namespace {

// Particles on a grid of the given spacing at cell centres inside the default T-bar, as a
// uniform-grid sampler would place them.
std::vector<Eigen::Vector3d> tbarGridParticles(double h) {
  const TBarDimensions d;
  std::vector<Eigen::Vector3d> points;
  for (double x = -0.15 + 0.5 * h; x < 0.15; x += h) {
    for (double y = -0.03 + 0.5 * h; y < 0.03; y += h) {
      for (double z = 0.5 * h; z < 0.30; z += h) {
        const bool in_leg = std::abs(x) < 0.5 * d.leg_width && z < d.leg_height;
        const bool in_bar = z > d.leg_height;
        if (in_leg || in_bar) points.emplace_back(x, y, z);
      }
    }
  }
  return points;
}

// A large smooth deformation: twist about z growing along the leg, plus some bending.
Eigen::Vector3d twist(const Eigen::Vector3d& p) {
  const double angle = 0.4 * p.z() / 0.3;  // 23 degrees at the top
  const double c = std::cos(angle), s = std::sin(angle);
  return Eigen::Vector3d(c * p.x() - s * p.y() - p.x() + 0.05 * p.z() * p.z(),
                         s * p.x() + c * p.y() - p.y(), -0.02 * p.x() * p.x());
}

TEST(DisplacementInterpolator, ReproducesALinearField) {
  const auto particles = tbarGridParticles(0.01);
  Eigen::Matrix3d gradient;
  gradient << 0.1, -0.2, 0.05, 0.3, 0.0, -0.1, 0.02, 0.04, -0.06;
  const Eigen::Vector3d offset(0.001, -0.002, 0.003);
  std::vector<Eigen::Vector3d> values;
  for (const auto& p : particles) values.push_back(offset + gradient * p);
  const DisplacementInterpolator field(particles, values);
  const SceneObject object = makeSceneObject(SceneKind::kTBar, 0.01);
  double worst = 0.0;
  for (const auto& v : object.mesh.vertices) worst = std::max(worst, (field.at(v) - (offset + gradient * v)).norm());
  EXPECT_LT(worst, 1e-5) << "linear field error " << worst << " m";
}

TEST(DisplacementInterpolator, SmoothTwistErrorAtMeshVerticesIsSmall) {
  const double h = 0.006;  // ~ 8000 particles in the T-bar, as in the DEM target
  const auto particles = tbarGridParticles(h);
  std::vector<Eigen::Vector3d> values;
  for (const auto& p : particles) values.push_back(twist(p));
  const DisplacementInterpolator field(particles, values);
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  double worst = 0.0, largest = 0.0, sum = 0.0;
  for (const auto& v : object.mesh.vertices) {
    const double error = (field.at(v) - twist(v)).norm();
    worst = std::max(worst, error);
    sum += error;
    largest = std::max(largest, twist(v).norm());
  }
  std::cout << "[ figure   ] MLS interpolation, " << particles.size() << " grid particles (h = " << h
            << " m), twist of 23 deg: max error " << worst * 1e3 << " mm, mean "
            << sum / object.mesh.vertices.size() * 1e3 << " mm, max |u| " << largest * 1e3 << " mm\n";
  EXPECT_LT(worst, 0.005 * largest);
  EXPECT_NEAR(field.typicalSpacing(), h, 1e-9);
}

TEST(DisplacementInterpolator, SmoothTwistFromRandomParticlesIsStillAccurate) {
  // Uniform random particles (what a random sampler gives): uneven gaps, clusters.
  std::mt19937 random(5);
  std::uniform_real_distribution<double> ux(-0.15, 0.15), uy(-0.03, 0.03), uz(0.0, 0.30);
  std::vector<Eigen::Vector3d> particles, values;
  while (particles.size() < 8000) {
    const Eigen::Vector3d p(ux(random), uy(random), uz(random));
    if (p.z() < 0.24 && std::abs(p.x()) > 0.03) continue;
    particles.push_back(p);
    values.push_back(twist(p));
  }
  const DisplacementInterpolator field(particles, values);
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  double worst = 0.0, largest = 0.0, sum = 0.0;
  for (const auto& v : object.mesh.vertices) {
    const double error = (field.at(v) - twist(v)).norm();
    worst = std::max(worst, error);
    sum += error;
    largest = std::max(largest, twist(v).norm());
  }
  std::cout << "[ figure   ] MLS interpolation, 8000 random particles: max error " << worst * 1e3
            << " mm, mean " << sum / object.mesh.vertices.size() * 1e3 << " mm, max |u| " << largest * 1e3
            << " mm\n";
  EXPECT_LT(worst, 0.01 * largest);
  EXPECT_NO_THROW(field.checkCovers(object.mesh.vertices, "the T-bar"));
}

TEST(DisplacementInterpolator, FlatOneLayerCloudStaysStable) {
  // A membrane sampled by a single layer: the fit must not blow up off the plane.
  std::vector<Eigen::Vector3d> particles, values;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) {
      particles.emplace_back(0.002 * i, 0.002 * j, 0.0005);
      values.emplace_back(0.0, 0.01 * particles.back().x(), 0.0);
    }
  }
  const DisplacementInterpolator field(particles, values);
  const Eigen::Vector3d u = field.at(Eigen::Vector3d(0.02, 0.02, 0.001));
  EXPECT_NEAR(u.y(), 0.01 * 0.02, 1e-6);
  EXPECT_NEAR(u.x(), 0.0, 1e-6);
}

TEST(DisplacementInterpolator, RefusesBadInputAndUncoveredPoints) {
  const auto particles = tbarGridParticles(0.01);
  std::vector<Eigen::Vector3d> values(particles.size(), Eigen::Vector3d::Zero());
  EXPECT_THROW(DisplacementInterpolator(particles, std::vector<Eigen::Vector3d>(3)), core::Error);
  EXPECT_THROW(DisplacementInterpolator(std::vector<Eigen::Vector3d>(particles.begin(), particles.begin() + 5),
                                        std::vector<Eigen::Vector3d>(5)),
               core::Error);
  auto bad = values;
  bad[7].x() = std::nan("");
  EXPECT_THROW(DisplacementInterpolator(particles, bad), core::Error);
  const DisplacementInterpolator field(particles, values);
  const SceneObject tbar = makeSceneObject(SceneKind::kTBar);
  EXPECT_NO_THROW(field.checkCovers(tbar.mesh.vertices, "the T-bar"));
  // The T-bar's particles do not cover a body twice as tall.
  std::vector<Eigen::Vector3d> taller = tbar.mesh.vertices;
  for (auto& v : taller) v.z() *= 2.0;
  EXPECT_THROW(field.checkCovers(taller, "a taller body"), core::Error);
}

}  // namespace
}  // namespace demnerf::render
