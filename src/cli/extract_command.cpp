// `demnerf extract`: the surface of a trained NeRF as a closed mesh (packages/geometry on the
// NeRF's density, sampled on cubic cells over the model's box).

#include <chrono>
#include <sstream>
#include <string>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "pipeline/model_geometry.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/nerf/model_io.hpp"

namespace demnerf::cli {
namespace {

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

Figures runExtract(const Arguments& arguments) {
  arguments.rejectUnknown({"model", "mesh", "resolution", "surface", "opacity", "threshold", "max-faces", "smooth",
                           "json", "quiet"});
  const std::string model_path = arguments.text("model");
  const std::string mesh_path = arguments.text("mesh");
  const dem_nerf::SurfaceDefaults defaults;  // shared with `demnerf sample` and nerf_node
  const int resolution = arguments.integer("resolution", defaults.resolution);
  if (resolution < 8 || resolution > 1024) {
    throw UsageError("option --resolution expects 8..1024, got " + std::to_string(resolution));
  }
  geometry::MeshExtractionConfig config;
  // The surface as rendered (opacity along the clearest axis) is the default; --threshold alone
  // keeps its old meaning (instant-ngp's density iso-surface).
  const std::string surface = arguments.text("surface", arguments.has("threshold") ? "density" : "opacity");
  try {
    config.surface = geometry::parseSurfaceDefinition(surface);
  } catch (const core::Error&) {
    throw UsageError("option --surface expects density or opacity, got '" + surface + "'");
  }
  config.opacity = arguments.number("opacity", defaults.opacity);
  config.threshold = arguments.number("threshold", config.threshold);
  // At 192 cells the T-bar's surface has ~340k faces; a budget of 200k costs ~3-5 s of edge collapse
  // (shortest edge first, midpoint placement: 2x faster than Lindstrom-Turk, same accuracy here).
  const int max_faces = arguments.integer("max-faces", 0);
  if (max_faces < 0) throw UsageError("option --max-faces expects a count >= 0 (0: keep every face)");
  config.simplification.max_faces = static_cast<std::size_t>(max_faces);
  config.simplification.fast = true;
  config.repair.smoothing_iterations = arguments.integer("smooth", 0);
  if (config.repair.smoothing_iterations < 0) throw UsageError("option --smooth expects a count >= 0");
  const auto start = std::chrono::steady_clock::now();
  const nerf::NerfModel model = nerf::loadModel(model_path);
  const geometry::DensityGrid grid = dem_nerf::densityGridOf(model, resolution);
  const geometry::MeshExtractionResult result = geometry::extractMesh(grid, config);
  core::writeMesh(mesh_path, result.mesh);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Figures{{"vertices", result.vertices},
                 {"faces", result.faces},
                 {"faces_before_simplification", result.simplification.faces_before},
                 {"max_faces", max_faces},
                 {"volume", result.volume},
                 {"area", result.area},
                 {"closed", result.closed},
                 {"surface", surface},
                 {"opacity", config.opacity},
                 {"threshold", config.threshold},
                 {"iso_value", result.iso_value},
                 {"resolution", resolution},
                 {"cell", grid.spacing.x()},
                 {"components_removed", result.repair.components_removed},
                 {"holes_filled", result.repair.holes_filled},
                 {"seconds", seconds},
                 {"mesh", mesh_path}};
}

}  // namespace

const Command kExtractCommand = {
    "extract", "surface mesh from a model's density",
    [] {
      // The defaults printed are the ones that run (dem_nerf::SurfaceDefaults, as nerf_node's).
      static const std::string text = "--model MODEL --mesh OUT.ply [--resolution " +
                                      std::to_string(dem_nerf::SurfaceDefaults{}.resolution) +
                                      " (cells along the longest side)] [--surface opacity|density] [--opacity " +
                                      number(dem_nerf::SurfaceDefaults{}.opacity) +
                                      "] [--threshold 2.5 (density surface)] [--max-faces 0 (0: keep all)] "
                                      "[--smooth 0] [--json]";
      return text.c_str();
    }(),
    runExtract};

}  // namespace demnerf::cli
