// The rough-surface sizing rule (DemGridConfig::rough_surface): the roughness measure reads flat
// faces and smooth curves as smooth, a NeRF-like bumpy face as rough, and only a rough body's grid
// is refined.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>
#include <string>

#include "../src/dem_config_check.hpp"
#include "../src/surface_roughness.hpp"
#include "demnerf/mechanics/box_particles.hpp"

namespace demnerf::mechanics {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The box's particles with each surface particle moved along its normal by a x sin(2 pi u / l)
// sin(2 pi v / l) (u, v its coordinates in the face) and its normal tilted to the bumps' slope:
// the few-mm bumps of a NeRF extraction on an otherwise flat face.
core::ParticleCloud bumpyBox(const Eigen::Vector3i& cells, double amplitude, double wavelength) {
  core::ParticleCloud cloud = makeBoxParticles(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0.1, 0.1), cells);
  const double k = 2 * kPi / wavelength;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.isSurface(i)) continue;
    const Eigen::Vector3d n = cloud.normals[i];
    int a = 0;
    n.cwiseAbs().maxCoeff(&a);
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double u = cloud.positions[i](b), v = cloud.positions[i](c);
    cloud.positions[i] += amplitude * std::sin(k * u) * std::sin(k * v) * n;
    Eigen::Vector3d tilted = n;
    tilted(b) -= n(a) * amplitude * k * std::cos(k * u) * std::sin(k * v);
    tilted(c) -= n(a) * amplitude * k * std::sin(k * u) * std::cos(k * v);
    cloud.normals[i] = tilted.normalized();
  }
  return cloud;
}

// Surface particles on a sphere of radius R (random directions), each with the sphere's normal.
core::ParticleCloud sphereSurface(double R, int count) {
  core::ParticleCloud cloud;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  const double area = 4 * kPi * R * R / count;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d n = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    cloud.append(R * n, 0.0, n, area);
  }
  return cloud;
}

TEST(SurfaceRoughness, FlatFacesAndSmoothCurvesReadAsSmooth) {
  const core::ParticleCloud box = makeBoxParticles(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0.1, 0.1), {50, 25, 25});
  EXPECT_LT(surfaceRoughness(box, 0.02), 1e-12);  // edges: the other face's particles are left out
  // A sphere of 5 cells' radius (10 mm cells, fitted over 20 mm): a plane would leave ~0.4 mm.
  const core::ParticleCloud sphere = sphereSurface(0.05, 20000);
  EXPECT_LT(surfaceRoughness(sphere, 0.02), 0.2 * 0.005 * 0.02);
}

TEST(SurfaceRoughness, BumpsOfAFewMillimetresReadAsRough) {
  // 1 mm bumps 8 mm apart on 4 mm particles (which sit on their crests and troughs): scatter about
  // a, against the 0.1 mm threshold at 20 mm.
  const double scatter = surfaceRoughness(bumpyBox({50, 25, 25}, 1e-3, 8e-3), 0.02);
  EXPECT_GT(scatter, 0.3e-3);
  EXPECT_LT(scatter, 1.05e-3);
}

TEST(SurfaceRoughness, OnlyARoughBodysGridIsRefined) {
  DemConfig config;  // the product's DEM: body_cells 2000, thickness_cells 6
  const Eigen::Vector3i cells(50, 25, 25);
  const double flat = resolvedDemConfig(config, bumpyBox(cells, 0.0, 8e-3)).config.grid.cell;
  const double rough = resolvedDemConfig(config, bumpyBox(cells, 1e-3, 8e-3)).config.grid.cell;
  EXPECT_NEAR(rough, config.grid.rough_cell_ratio * flat, 1e-9);
  config.grid.rough_surface = 0.0;  // off
  EXPECT_NEAR(resolvedDemConfig(config, bumpyBox(cells, 1e-3, 8e-3)).config.grid.cell, flat, 1e-12);
  // A ragged body keeps the surface_cells cap (the fox: its cut cells' set-up).
  config.grid.rough_surface = 0.005;
  config.grid.surface_cells = 20;  // sqrt(A / 20) = 71 mm, above the body's rules
  EXPECT_NEAR(resolvedDemConfig(config, bumpyBox(cells, 1e-3, 8e-3)).config.grid.cell, std::sqrt(0.1 / 20), 1e-9);
  config.grid.surface_cells = DemGridConfig{}.surface_cells;
  // Fewer particles (686) than body_cells (2000) keep the cell, though their surface reads rough
  // and 0.6 of their 14 mm spacing would allow the finer one.
  const Eigen::Vector3i sparse(14, 7, 7);
  const core::ParticleCloud sparse_rough = bumpyBox(sparse, 1e-3, 30e-3);
  const double radius = std::max(2 * flat, 3 * surfaceParticleSpacing(sparse_rough));
  ASSERT_GT(surfaceRoughness(sparse_rough, radius), config.grid.rough_surface * radius);
  ASSERT_LT(0.6 * resolvedDemConfig(config, sparse_rough).spacing, config.grid.rough_cell_ratio * flat);  // the cells' floor
  EXPECT_NEAR(resolvedDemConfig(config, sparse_rough).config.grid.cell,
              resolvedDemConfig(config, bumpyBox(sparse, 0.0, 30e-3)).config.grid.cell, 1e-12);
  // Never finer than 0.6 particle spacings: 25 mm particles keep their 15 mm cells.
  const Eigen::Vector3i coarse(8, 4, 4);
  EXPECT_NEAR(resolvedDemConfig(config, bumpyBox(coarse, 1e-3, 8e-3)).config.grid.cell,
              resolvedDemConfig(config, bumpyBox(coarse, 0.0, 8e-3)).config.grid.cell, 1e-12);
}

// As many particles as body_cells are enough for the finer cell, though fewer than the finer grid
// has body cells: the NeRF T-bar's 1/6 clouds (3,400 particles, 3,900 cells at 7.88 mm), whose
// energy the finer cell brings within 1 % now that their nested start factorises once.
TEST(SurfaceRoughness, ACloudWithMoreParticlesThanBodyCellsIsRefined) {
  DemConfig config;
  config.grid.thickness_cells = 0;  // the body's rule sizes the box's cell: (2e-3 / 2000)^(1/3) = 10 mm
  const Eigen::Vector3i cells(22, 11, 11);  // 2,662 particles, 9.1 mm apart; 3,906 cells of 8 mm
  const core::ParticleCloud rough = bumpyBox(cells, 1e-3, 30e-3);
  ASSERT_GE(static_cast<double>(rough.size()), config.grid.body_cells);
  const double flat = resolvedDemConfig(config, bumpyBox(cells, 0.0, 30e-3)).config.grid.cell;
  ASSERT_NEAR(flat, 0.01, 1e-6);
  const double finer = config.grid.rough_cell_ratio * flat;
  ASSERT_LT(static_cast<double>(rough.size()), 2e-3 / (finer * finer * finer));
  const double radius = std::max(2 * flat, 3 * surfaceParticleSpacing(rough));
  ASSERT_GT(surfaceRoughness(rough, radius), config.grid.rough_surface * radius);
  const DemConfig resolved = resolvedDemConfig(config, rough).config;
  EXPECT_NEAR(resolved.grid.cell, finer, 1e-9);
  // Its nested level keeps the unrefined grid's coarse cell: it only starts the fine Newton.
  EXPECT_NEAR(resolved.grid.cell * resolved.grid.nested_ratio, flat * config.grid.nested_ratio, 1e-9);
}

// A rough cloud whose particles are too far apart or too few for the finer cell (the NeRF T-bar's
// Poisson 1/6 clouds: about 1,580 particles, and Voronoi volumes put their 90th-percentile spacing
// at 16.3 mm, whose 0.6 is above the 7.88 mm the surface asks for) keeps the coarser cell and says
// so, with the spacing that would let the grid refine; a smooth cloud and a rough one that is
// refined say nothing.
TEST(SurfaceRoughness, ARoughSurfaceTheParticlesCannotRefineWarnsOfAStiffAnswer) {
  DemConfig config;
  config.grid.thickness_cells = 0;  // the body's rule: 10 mm cells, as above
  const Eigen::Vector3i cells(22, 11, 11);
  core::ParticleCloud rough = bumpyBox(cells, 1e-3, 30e-3);
  const double flat = resolvedDemConfig(config, bumpyBox(cells, 0.0, 30e-3)).config.grid.cell;
  ASSERT_NEAR(flat, 0.01, 1e-6);
  EXPECT_EQ(resolvedDemConfig(config, rough).coarse_grid, "");  // refined to 8 mm: nothing to say
  // Uneven interior volumes of the same total: 15 % of the interior particles carry 5 shares, the
  // rest 0.25/0.85 of one, so the 90th percentile's spacing is 5^(1/3) x 9.1 = 15.6 mm (floor 9.4 mm).
  std::size_t interior = 0;
  for (std::size_t i = 0; i < rough.size(); ++i)
    if (rough.volumes[i] > 0 && interior++ % 20 < 3) rough.volumes[i] *= 5.0;
    else if (rough.volumes[i] > 0) rough.volumes[i] *= 0.25 / 0.85;
  double volume = 0.0;
  for (double v : rough.volumes) volume += v;
  const double body = std::cbrt(volume / config.grid.body_cells);  // 0.1 % above `flat`
  const ResolvedDemConfig kept = resolvedDemConfig(config, rough);
  const double floor = 0.6 * kept.spacing;
  ASSERT_GT(floor, config.grid.rough_cell_ratio * body);
  ASSERT_LT(floor, body);
  EXPECT_NEAR(kept.config.grid.cell, floor, 1e-9);  // as fine as the particles allow, no finer
  EXPECT_NE(kept.coarse_grid.find("the surface is rough"), std::string::npos) << kept.coarse_grid;
  EXPECT_NE(kept.coarse_grid.find("expect a stiff answer"), std::string::npos) << kept.coarse_grid;
  std::ostringstream closer;
  closer.precision(3);
  closer << config.grid.rough_cell_ratio * body / floor << " times as far apart";
  EXPECT_NE(kept.coarse_grid.find(closer.str()), std::string::npos) << kept.coarse_grid;
  // The same volumes on the smooth box: no refinement was asked for, so nothing is said.
  core::ParticleCloud smooth = bumpyBox(cells, 0.0, 30e-3);
  smooth.volumes = rough.volumes;
  EXPECT_EQ(resolvedDemConfig(config, smooth).coarse_grid, "");
  // Too few particles (1,176, fewer than body_cells) keep the body's cell and say that instead.
  const ResolvedDemConfig few = resolvedDemConfig(config, bumpyBox({14, 7, 7}, 1e-3, 30e-3));
  EXPECT_NEAR(few.config.grid.cell, flat, 1e-9);
  EXPECT_NE(few.coarse_grid.find("1176 particles are fewer than the 2000"), std::string::npos) << few.coarse_grid;
  EXPECT_EQ(resolvedDemConfig(config, bumpyBox({14, 7, 7}, 0.0, 30e-3)).coarse_grid, "");
}

}  // namespace
}  // namespace demnerf::mechanics
