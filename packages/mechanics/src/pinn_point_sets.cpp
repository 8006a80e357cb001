#include "pinn_point_sets.hpp"

#include <algorithm>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/held_face.hpp"

namespace demnerf::mechanics {

PinnPointSets pinnPointSets(const core::Scenario& scenario, const core::ParticleCloud& cloud) {
  const auto traction = particleTractions(scenario, cloud);
  const Dirichlet fixed = resolveHeldParticles(scenario, cloud, heldFaces(scenario, cloud));
  std::vector<Eigen::Vector3d> free(cloud.size(), Eigen::Vector3d::Ones());
  for (std::size_t k = 0; k < fixed.index.size(); ++k)
    free[fixed.index[k]] = Eigen::Vector3d::Ones() - fixed.mask[k].cast<double>();
  PinnPointSets sets;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.volumes[i] > 0 && !free[i].isZero()) {
      sets.residual_points.push_back(cloud.positions[i]);
      sets.residual_free.push_back(free[i]);
      sets.residual_volume.push_back(cloud.volumes[i]);
    }
    if (cloud.isSurface(i) && !free[i].isZero()) {
      sets.surface_points.push_back(cloud.positions[i]);
      sets.surface_normal.push_back(cloud.normals[i].normalized());
      sets.surface_traction.push_back(traction[i]);
      sets.surface_free.push_back(free[i]);
      sets.surface_area.push_back(cloud.areas[i]);
    }
    sets.max_traction = std::max(sets.max_traction, traction[i].norm());
  }
  if (sets.residual_points.empty())
    throw core::Error("PINN: no particle with volume > 0 outside the fixtures carries the equilibrium residual");
  for (std::size_t k = 0; k < fixed.index.size(); ++k) {
    sets.fixed_points.push_back(cloud.positions[fixed.index[k]]);
    sets.fixed_mask.push_back(fixed.mask[k].cast<double>());
    sets.max_prescribed = std::max(sets.max_prescribed, fixed.value[k].norm());
  }
  sets.fixed_value = fixed.value;
  return sets;
}

}  // namespace demnerf::mechanics
