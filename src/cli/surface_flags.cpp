#include "surface_flags.hpp"

#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include "command.hpp"
#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/geometry/object_isolation.hpp"

namespace demnerf::cli {
namespace {

// "dx,dy,dz", a direction (any length but zero) for --solid-behind.
Eigen::Vector3d direction(const std::string& text) {
  const std::optional<std::vector<double>> numbers = geometry::parseNumberList(text);
  if (!numbers || numbers->size() != 3 || Eigen::Vector3d::Map(numbers->data()).isZero()) {
    throw UsageError("option --solid-behind expects a direction dx,dy,dz (from the object towards the cameras, "
                     "not zero), got '" + text + "'");
  }
  return Eigen::Vector3d::Map(numbers->data());
}

// The training frames of the capture in DIR (poses and intrinsics only, no images): the split
// `demnerf train --data DIR` fits, so carving trusts only views the model learnt from.
std::vector<core::Frame> trainingFrames(const std::string& directory) {
  core::DatasetOptions options;
  options.load_images = false;
  try {
    return core::loadDataset(directory, options).train;
  } catch (const core::Error& error) {
    throw UsageError(std::string("option --solid-cameras expects the capture's dataset folder: ") + error.what());
  }
}

// --solid-cameras DIR [--solid-views N]: space carving against the capture's training cameras,
// attached as nerf_node attaches its keyframes (dem_nerf::withTrainingCameras).
void carvingFlags(const Arguments& arguments, dem_nerf::SurfaceConfig* config) {
  if (!arguments.has("solid-cameras")) {
    if (arguments.has("solid-views"))
      throw UsageError("option --solid-views counts the cameras of --solid-cameras DIR; give that too");
    return;
  }
  if (arguments.has("solid-behind"))
    throw UsageError("options --solid-cameras and --solid-behind are alternatives; give one (--solid-cameras is tighter)");
  config->solid_views = arguments.integer("solid-views", 1);
  if (config->solid_views < 1) throw UsageError("option --solid-views expects a count >= 1 (1: the visual hull)");
  if (config->mesh.solid.radius == 0.0) {
    throw UsageError("option --solid-cameras needs --solid-radius R > 0 as well: the closing shuts the slits grazing "
                     "views leave in the carved fill (the fox: --solid-radius 0.16 --solid-views 4)");
  }
  const std::string directory = arguments.text("solid-cameras");
  try {
    *config = dem_nerf::withTrainingCameras(*config, trainingFrames(directory),
                                             "the training split of '" + directory + "'");
  } catch (const core::Error& error) {
    throw UsageError(std::string("option --solid-views: ") + error.what());
  }
}

}  // namespace

std::set<std::string> surfaceFlagNames() {
  return {"resolution", "surface", "opacity", "threshold", "max-faces", "smooth", "box", "max-second-piece", "solid-radius", "solid-behind",
          "solid-cameras", "solid-views"};
}

dem_nerf::SurfaceConfig surfaceFlags(const Arguments& arguments) {
  dem_nerf::SurfaceConfig config;
  config.resolution = arguments.integer("resolution", config.resolution);
  if (config.resolution < 8 || config.resolution > 1024)
    throw UsageError("option --resolution expects 8..1024, got " + std::to_string(config.resolution));
  const std::string surface = arguments.text("surface", arguments.has("threshold") ? "density" : "opacity");
  try {
    config.mesh.surface = geometry::parseSurfaceDefinition(surface);
  } catch (const core::Error&) {
    throw UsageError("option --surface expects density or opacity, got '" + surface + "'");
  }
  config.mesh.opacity = arguments.number("opacity", config.mesh.opacity);
  if (!(config.mesh.opacity > 0.0 && config.mesh.opacity < 1.0)) throw UsageError("option --opacity expects a value in (0, 1)");
  config.mesh.threshold = arguments.number("threshold", config.mesh.threshold);
  if (!(config.mesh.threshold > 0.0)) throw UsageError("option --threshold expects a density > 0");
  // At 192 cells the T-bar's surface has ~340k faces; a budget of 200k costs ~3-5 s of edge collapse.
  const int max_faces = arguments.integer("max-faces", 0);
  if (max_faces < 0) throw UsageError("option --max-faces expects a count >= 0 (0: keep every face)");
  config.mesh.simplification.max_faces = static_cast<std::size_t>(max_faces);
  config.mesh.repair.smoothing_iterations = arguments.integer("smooth", config.mesh.repair.smoothing_iterations);
  if (config.mesh.repair.smoothing_iterations < 0) throw UsageError("option --smooth expects a count >= 0");
  if (arguments.has("box")) {
    try {
      config.box = geometry::parseBox(arguments.text("box"));
    } catch (const core::Error& error) {
      throw UsageError(std::string("option --box: ") + error.what());
    }
  }
  config.isolation.max_second_piece_fraction =
      arguments.number("max-second-piece", config.isolation.max_second_piece_fraction);
  config.mesh.solid.radius = arguments.number("solid-radius", config.mesh.solid.radius);
  if (!(config.mesh.solid.radius >= 0.0) || !std::isfinite(config.mesh.solid.radius))
    throw UsageError("option --solid-radius expects a length >= 0 in the scene's units (0: no closing)");
  if (arguments.has("solid-behind")) config.mesh.solid.behind = direction(arguments.text("solid-behind"));
  carvingFlags(arguments, &config);
  return config;
}

std::string surfaceFlagsUsage() {
  const dem_nerf::SurfaceConfig defaults;  // the defaults printed are the ones that run, as nerf_node's
  std::ostringstream text;
  text << "[--resolution " << defaults.resolution << " (cells along the longest side)] [--surface opacity|density] "
       << "[--opacity " << defaults.mesh.opacity << "] [--threshold " << defaults.mesh.threshold
       << " (density surface)] [--max-faces 0 (0: keep all)] [--smooth " << defaults.mesh.repair.smoothing_iterations
       << " (Taubin passes)] "
       << "[--box xmin,ymin,zmin,xmax,ymax,zmax (the scene's frame: mesh only the object inside, its largest piece)] "
       << "[--max-second-piece " << defaults.isolation.max_second_piece_fraction
       << " (refuse a box whose second piece has this fraction of the largest's size)] "
       << "[--solid-radius " << defaults.mesh.solid.radius
       << " (> 0: close tunnels narrower than about twice this, in the scene's units, and fill cavities)] "
       << "[--solid-cameras DIR (with --solid-radius; the capture's dataset: fill what none of its training cameras "
       << "saw as empty; --solid-views N: what fewer than N saw) | "
       << "--solid-behind dx,dy,dz (towards the cameras of a one-sided capture: fill what the body hides)]";
  return text.str();
}

}  // namespace demnerf::cli
