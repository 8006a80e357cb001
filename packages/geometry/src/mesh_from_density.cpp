#include "demnerf/geometry/mesh_from_density.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/iso_surface.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/optical_depth.hpp"

namespace demnerf::geometry {

SurfaceDefinition parseSurfaceDefinition(const std::string& name) {
  if (name == "density") return SurfaceDefinition::kDensity;
  if (name == "opacity") return SurfaceDefinition::kOpacity;
  throw core::Error("unknown surface definition '" + name + "': expected density or opacity");
}

namespace {

// The field the surface is cut from and its level: the density itself, or the optical depth
// seen from outside for an opacity surface. Throws core::Error for a level out of range.
DensityGrid surfaceField(const DensityGrid& grid, const MeshExtractionConfig& config, double* level) {
  if (config.surface == SurfaceDefinition::kOpacity) {
    if (!(config.opacity > 0 && config.opacity < 1)) {
      std::ostringstream message;
      message << "surface opacity " << config.opacity << " must be in (0, 1), e.g. 0.5";
      throw core::Error(message.str());
    }
    *level = -std::log(1.0 - config.opacity);
    return axisOpticalDepth(grid);
  }
  if (!std::isfinite(config.threshold)) throw core::Error("density threshold must be finite, got nan/inf");
  *level = config.threshold;
  return grid;
}

std::string noSurfaceMessage(const DensityGrid& field, const MeshExtractionConfig& config) {
  const auto range = std::minmax_element(field.values.begin(), field.values.end());
  std::ostringstream message;
  if (config.surface == SurfaceDefinition::kOpacity) {
    const double deepest = *range.second;
    message << "no surface at opacity " << config.opacity << ": no grid node lies deeper than optical depth "
            << deepest << " (opacity " << 1.0 - std::exp(-deepest) << ") from outside; the field is nearly "
            << "transparent (an untrained model?) - lower the opacity or use --surface density";
  } else {
    message << "no surface at density threshold " << config.threshold << ": the grid's densities range from "
            << *range.first << " to " << *range.second << "; choose a threshold inside that range";
  }
  return message.str();
}

}  // namespace

MeshExtractionResult extractMesh(const DensityGrid& grid, const MeshExtractionConfig& config) {
  grid.validate();
  MeshExtractionResult result;
  DensityGrid field = surfaceField(grid, config, &result.iso_value);
  // The solid is taken on the field the surface is cut from, at its own level, so an opacity
  // surface's tunnels close the same way as a density surface's.
  if (config.solid.enabled()) field = solidifyField(field, result.iso_value, config.solid, &result.solid);
  const core::TriangleMesh raw = extractIsoSurface(field, result.iso_value);
  if (raw.faces.empty()) throw core::Error(noSurfaceMessage(field, config));
  result.mesh = repairMesh(raw, config.repair, &result.repair);
  result.mesh = simplifyMesh(result.mesh, config.simplification, &result.simplification);
  const MeshSummary summary = analyzeMesh(result.mesh);
  result.vertices = summary.vertices;
  result.faces = summary.faces;
  result.volume = summary.volume();
  result.area = summary.area;
  result.closed = summary.closed();
  result.topology = surfaceTopology(result.mesh);
  return result;
}

}  // namespace demnerf::geometry
