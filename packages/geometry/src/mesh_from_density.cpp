#include "demnerf/geometry/mesh_from_density.hpp"

#include <algorithm>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/iso_surface.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"

namespace demnerf::geometry {

MeshExtractionResult extractMesh(const DensityGrid& grid, const MeshExtractionConfig& config) {
  grid.validate();
  core::TriangleMesh raw = extractIsoSurface(grid, config.threshold);
  if (raw.faces.empty()) {
    const auto range = std::minmax_element(grid.values.begin(), grid.values.end());
    std::ostringstream message;
    message << "no surface at density threshold " << config.threshold << ": the grid's densities range from "
            << *range.first << " to " << *range.second << "; choose a threshold inside that range";
    throw core::Error(message.str());
  }
  MeshExtractionResult result;
  result.mesh = repairMesh(raw, config.repair, &result.repair);
  const MeshSummary summary = analyzeMesh(result.mesh);
  result.vertices = summary.vertices;
  result.faces = summary.faces;
  result.volume = summary.volume();
  result.area = summary.area;
  result.closed = summary.closed();
  return result;
}

}  // namespace demnerf::geometry
