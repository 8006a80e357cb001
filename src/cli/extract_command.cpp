// `demnerf extract`: the surface of a trained NeRF as a closed mesh (packages/geometry on the
// density grid that packages/nerf exports).

#include <chrono>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"

#if __has_include("demnerf/nerf/model_io.hpp")
#include "demnerf/nerf/model_io.hpp"
#define DEMNERF_EXTRACT_HAS_NERF 1
#endif

namespace demnerf::cli {
namespace {

Figures runExtract(const Arguments& arguments) {
  arguments.rejectUnknown({"model", "mesh", "resolution", "threshold", "smooth", "json", "quiet"});
  const std::string model_path = arguments.text("model");
  const std::string mesh_path = arguments.text("mesh");
  const int resolution = arguments.integer("resolution", 256);
  if (resolution < 8 || resolution > 1024) {
    throw UsageError("option --resolution expects 8..1024, got " + std::to_string(resolution));
  }
  geometry::MeshExtractionConfig config;
  config.threshold = arguments.number("threshold", config.threshold);
  config.repair.smoothing_iterations = arguments.integer("smooth", 0);
  if (config.repair.smoothing_iterations < 0) throw UsageError("option --smooth expects a count >= 0");
#ifdef DEMNERF_EXTRACT_HAS_NERF
  const auto start = std::chrono::steady_clock::now();
  const nerf::NerfModel model = nerf::loadModel(model_path);
  // The export samples cell centres of a resolution^3 lattice over the model's box, x fastest.
  geometry::DensityGrid grid;
  grid.dims = Eigen::Vector3i::Constant(resolution);
  const nerf::Box box = model.bounds();
  for (int a = 0; a < 3; ++a) {
    grid.spacing[a] = static_cast<double>(box.size(a)) / resolution;
    grid.origin[a] = box.min[a] + 0.5 * grid.spacing[a];
  }
  grid.values = model.densityGrid(resolution);
  const geometry::MeshExtractionResult result = geometry::extractMesh(grid, config);
  core::writeMesh(mesh_path, result.mesh);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Figures{{"vertices", result.vertices}, {"faces", result.faces},     {"volume", result.volume},
                 {"area", result.area},         {"closed", result.closed},   {"threshold", config.threshold},
                 {"resolution", resolution},    {"components_removed", result.repair.components_removed},
                 {"holes_filled", result.repair.holes_filled}, {"seconds", seconds}, {"mesh", mesh_path}};
#else
  (void)model_path;
  (void)mesh_path;
  throw NotBuiltYet("demnerf extract needs the NeRF library (packages/nerf), which is not built yet in this build");
#endif
}

}  // namespace

const Command kExtractCommand = {
    "extract", "surface mesh from a model's density",
    "--model MODEL --mesh OUT.ply [--resolution 256] [--threshold 2.5] [--smooth 0] [--json]", runExtract};

}  // namespace demnerf::cli
