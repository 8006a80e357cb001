#include "demnerf/mechanics/particle_surface.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/iso_surface.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"
#include "demnerf/mechanics/surface_sharpening.hpp"

namespace demnerf::mechanics {

bool particlesDescribeSurface(const core::ParticleCloud& cloud) {
  bool any = false;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!(cloud.areas[i] > 0.0)) continue;
    if (cloud.volumes[i] > 0.0 || cloud.normals[i].squaredNorm() == 0.0) return false;
    any = true;
  }
  return any;
}

core::TriangleMesh surfaceOfParticles(const core::ParticleCloud& cloud, double step, bool sharpen) {
  ParticleInsideTest inside(cloud);
  inside.setBlendRoughFaces(false);  // the nearest plane: see setBlendRoughFaces
  return surfaceOfParticles(cloud, inside, step, sharpen);
}

core::TriangleMesh surfaceOfParticles(const core::ParticleCloud& cloud, const ParticleInsideTest& inside, double step,
                                      bool sharpen) {
  if (!(step > 0.0) || !std::isfinite(step))
    throw core::Error("particle surface: the sampling step must be a positive length, got " + std::to_string(step));
  if (!particlesDescribeSurface(cloud))
    throw core::Error("particle surface: the particles do not place the body's surface (none has an area and a "
                      "normal without a volume); sample the body with `demnerf sample` or pass its surface (--mesh)");
  // The surface particles lie on the surface, so their box is the body's. Each axis takes a whole
  // number of samples over it, offset by half a sample: faces on the box (a block's, the T-bar's
  // base and ends) then fall midway between samples, where the crossing is exact, not on a sample,
  // where the extraction would nudge it off by a thousandth of a step. Two more samples all round
  // are empty, so the extracted surface is closed.
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), upper = -lower;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.areas[i] > 0.0) {
      lower = lower.cwiseMin(cloud.positions[i]);
      upper = upper.cwiseMax(cloud.positions[i]);
    }
  const Eigen::Vector3d intervals = ((upper - lower) / step).array().ceil().max(1.0);
  if ((intervals.array() + 6.0).prod() > 2e7)
    throw core::Error("particle surface: a step of " + std::to_string(step) +
                      " m gives too many samples; use a larger one");
  geometry::DensityGrid field;
  for (int a = 0; a < 3; ++a) field.spacing(a) = upper(a) > lower(a) ? (upper(a) - lower(a)) / intervals(a) : step;
  field.origin = lower - 2.5 * field.spacing;
  field.dims = (intervals.array() + 6.0).cast<int>().matrix();
  field.values.resize(static_cast<std::size_t>(field.dims.prod()));
  // Positive inside: the iso-surface's "density" is the depth below the surface.
  for (int k = 0; k < field.dims.z(); ++k)
    for (int j = 0; j < field.dims.y(); ++j)
      for (int i = 0; i < field.dims.x(); ++i)
        field.values[field.index(i, j, k)] = static_cast<float>(-inside.signedDistance(field.node(i, j, k)));
  core::TriangleMesh surface = geometry::extractIsoSurface(field, 0.0);
  if (surface.faces.empty())
    throw core::Error("particle surface: no point sampled every " + std::to_string(step) +
                      " m lies inside the particles' body; use a smaller step");
  if (sharpen) sharpenEdges(surface, inside, step);
  return surface;
}

}  // namespace demnerf::mechanics
