#pragma once
// A scenario's loads as forces at points of the surface the particles describe, spread evenly over
// the loaded patch whichever sampler placed the particles (the default DEM's load quadrature).
//
// Why not at the surface particles themselves: a load spread over a random cloud's surface particles
// is a set of point forces as uneven as the sampler (a random cloud at 1/6 of the cuboid puts 37
// particles on its loaded end, two or three in one grid cell and none in the next). The feature
// grid resolves that unevenness, and a rough load does extra work on the dimples it makes: the
// cuboid twist came out 3.2 % (1/6), 1.5 % (1/10) and 0.6 % (1/15) too low in energy on random
// clouds, about as 1 / (loaded particles), and within 0.4 % on grid and Poisson clouds (docs/
// dem_feature_grid.md, "Loads spread over the surface"). The FEM integrates the same traction
// over the exact faces.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

struct SurfaceLoads {
  std::vector<Eigen::Vector3d> points;  ///< on the surface (or, for a load that falls back, particles)
  std::vector<Eigen::Vector3d> forces;  ///< N at full load; each load's force and torque are exact
};

/// The surface inside each load's region is integrated on a lattice of spacing `step` (m) near it:
/// each lattice point within `step` of the surface (ParticleInsideTest's signed distance d to the
/// nearest surface particles' tangent planes) stands for step^2 (1 - |d| / step) of the surface at
/// its projection x - d n, a hat in d whose sum over the lattice is exact for a plane parallel to a
/// lattice axis and within rounding of it otherwise, and whose points the region clips at the
/// resolution `step`. The load's wrench is spread over those points as particleTractions() spreads
/// it over particles (spreadWrench). A load whose region holds surface particles but none of these
/// points (a region smaller than `step`) keeps particleTractions()'s forces at those particles.
/// A region whose lattice would exceed 4 million points (a half-space, or a box around the whole
/// body, on a fine grid) gets a coarser step.
/// Throws core::Error as particleTractions() does for a load that selects no surface particle.
SurfaceLoads surfaceLoads(const core::Scenario& scenario, const core::ParticleCloud& cloud, double step);

}  // namespace demnerf::mechanics
