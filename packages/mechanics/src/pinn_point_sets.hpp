#pragma once
// The PINN's point sets for a scenario (torch-free): where the equilibrium residual, the traction
// condition and the prescribed displacements are enforced. Private to packages/mechanics/src.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

/// A component prescribed by a fixture at a particle carries a reaction there: neither the
/// equilibrium nor the traction condition holds in that component, so each set keeps a mask of
/// the free components (1 free, 0 prescribed).
struct PinnPointSets {
  std::vector<Eigen::Vector3d> residual_points, residual_free;  ///< particles with volume, not fully fixed
  std::vector<double> residual_volume;
  std::vector<Eigen::Vector3d> surface_points, surface_normal, surface_traction, surface_free;
  std::vector<double> surface_area;
  std::vector<Eigen::Vector3d> fixed_points, fixed_value, fixed_mask;
  double max_traction = 0.0;    ///< Pa, at full load
  double max_prescribed = 0.0;  ///< m, the largest prescribed displacement
};

/// core::Error when no particle is left to carry the equilibrium residual.
PinnPointSets pinnPointSets(const core::Scenario& scenario, const core::ParticleCloud& cloud);

}  // namespace demnerf::mechanics
