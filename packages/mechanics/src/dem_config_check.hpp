#pragma once
// The DEM's settings checked against a particle cloud before anything is built. Private to
// packages/mechanics/src (no torch here).

#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/dem_solver.hpp"

namespace demnerf::mechanics {

/// The spacing of the interior particles: the cube root of the 90th percentile of the particle
/// volumes (0 without volumes).
double interiorParticleSpacing(const core::ParticleCloud& cloud);

/// A config checked against its particles, with the spacing it was checked against.
struct ResolvedDemConfig {
  DemConfig config;
  double spacing = 0.0;  ///< interiorParticleSpacing() of the cloud (m)
  /// Why the answer will be stiff (empty: no reason known): the particles are too coarse for the
  /// automatic grid to put kFewestCellsAcross cells across the body's mean thickness, or for the
  /// finer cells their rough surface asks for (both joined by "; ").
  std::string coarse_grid;
};

/// `config` with grid.cell resolved from grid.spacings or grid.body_cells; core::Error naming the
/// setting and a value that works when a setting is out of range or the grid does not suit the
/// particles.
ResolvedDemConfig resolvedDemConfig(DemConfig config, const core::ParticleCloud& cloud);

}  // namespace demnerf::mechanics
