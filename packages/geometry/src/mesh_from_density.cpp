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

MeshExtractionResult extractMesh(const DensityGrid& grid, const MeshExtractionConfig& config) {
  grid.validate();
  MeshExtractionResult result;
  core::TriangleMesh raw;
  if (config.surface == SurfaceDefinition::kOpacity) {
    if (!(config.opacity > 0 && config.opacity < 1)) {
      std::ostringstream message;
      message << "surface opacity " << config.opacity << " must be in (0, 1), e.g. 0.5";
      throw core::Error(message.str());
    }
    result.iso_value = -std::log(1.0 - config.opacity);
    const DensityGrid depth = axisOpticalDepth(grid);
    raw = extractIsoSurface(depth, result.iso_value);
    if (raw.faces.empty()) {
      const double deepest = *std::max_element(depth.values.begin(), depth.values.end());
      std::ostringstream message;
      message << "no surface at opacity " << config.opacity << ": no grid node lies deeper than optical depth "
              << deepest << " (opacity " << 1.0 - std::exp(-deepest) << ") from outside; the field is nearly "
              << "transparent (an untrained model?) - lower the opacity or use --surface density";
      throw core::Error(message.str());
    }
  } else {
    if (!std::isfinite(config.threshold)) throw core::Error("density threshold must be finite, got nan/inf");
    result.iso_value = config.threshold;
    raw = extractIsoSurface(grid, config.threshold);
    if (raw.faces.empty()) {
      const auto range = std::minmax_element(grid.values.begin(), grid.values.end());
      std::ostringstream message;
      message << "no surface at density threshold " << config.threshold << ": the grid's densities range from "
              << *range.first << " to " << *range.second << "; choose a threshold inside that range";
      throw core::Error(message.str());
    }
  }
  result.mesh = repairMesh(raw, config.repair, &result.repair);
  result.mesh = simplifyMesh(result.mesh, config.simplification, &result.simplification);
  const MeshSummary summary = analyzeMesh(result.mesh);
  result.vertices = summary.vertices;
  result.faces = summary.faces;
  result.volume = summary.volume();
  result.area = summary.area;
  result.closed = summary.closed();
  return result;
}

}  // namespace demnerf::geometry
