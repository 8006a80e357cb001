#pragma once
// Particles of an axis-aligned box by the midpoint rule: for tests, benchmarks and demos that
// need a body without running the geometry stage.

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

/// `cells` cells per axis over [lower, upper]: one interior particle at each cell centre with
/// the cell's volume, and one surface particle at the centre of each boundary cell face with
/// its area and outward normal (volume 0). Volumes sum to the box volume, areas to its surface.
core::ParticleCloud makeBoxParticles(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                     const Eigen::Vector3i& cells);

/// Closed triangle surface of the box [lower, upper] (12 outward counter-clockwise triangles).
core::TriangleMesh boxSurface(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper);

}  // namespace demnerf::mechanics
