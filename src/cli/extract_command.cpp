// `demnerf extract`: the surface of a trained NeRF as a closed mesh (packages/geometry on the
// NeRF's density, sampled on cubic cells over the model's box, or over a user's box around one
// object of a real capture).

#include <chrono>
#include <string>
#include <set>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "pipeline/model_geometry.hpp"
#include "surface_flags.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"
#include "demnerf/nerf/model_io.hpp"

namespace demnerf::cli {
namespace {

Figures runExtract(const Arguments& arguments) {
  std::set<std::string> known = surfaceFlagNames();
  known.insert({"model", "mesh", "json", "quiet"});
  arguments.rejectUnknown(known);
  const std::string model_path = arguments.text("model");
  const std::string mesh_path = arguments.text("mesh");
  const dem_nerf::SurfaceConfig config = surfaceFlags(arguments);  // shared with `demnerf sample` and nerf_node
  const auto start = std::chrono::steady_clock::now();
  const nerf::NerfModel model = nerf::loadModel(model_path);
  geometry::IsolationReport pieces;
  const geometry::MeshExtractionResult result = dem_nerf::extractSurface(model, config, &pieces);
  core::writeMesh(mesh_path, result.mesh);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Figures{{"vertices", result.vertices},
                 {"faces", result.faces},
                 {"faces_before_simplification", result.simplification.faces_before},
                 {"max_faces", static_cast<int>(config.mesh.simplification.max_faces)},
                 {"volume", result.volume},
                 {"area", result.area},
                 {"closed", result.closed},
                 {"surface", config.mesh.surface == geometry::SurfaceDefinition::kOpacity ? "opacity" : "density"},
                 {"opacity", config.mesh.opacity},
                 {"threshold", config.mesh.threshold},
                 {"iso_value", result.iso_value},
                 {"resolution", config.resolution},
                 {"box", config.box ? geometry::formatBox(*config.box) : std::string("model bounds")},
                 {"pieces_in_box", pieces.pieces},
                 {"nodes_dropped", pieces.nodes_dropped},
                 {"components_removed", result.repair.components_removed},
                 {"holes_filled", result.repair.holes_filled},
                 {"solid_radius", config.mesh.solid.radius},
                 {"solid_behind", {config.mesh.solid.behind.x(), config.mesh.solid.behind.y(), config.mesh.solid.behind.z()}},
                 {"solid_cameras", config.mesh.solid.cameras.size()},
                 {"solid_views", config.solid_views},
                 {"solid_hidden_nodes", result.solid.hidden_nodes},
                 {"solid_unseen_nodes", result.solid.unseen_nodes},
                 {"solid_radius_cells", result.solid.radius_cells},
                 {"solid_closed_nodes", result.solid.closed_nodes},
                 {"solid_cavity_nodes", result.solid.cavity_nodes},
                 {"surface_components", result.topology.components},
                 {"euler_characteristic", result.topology.euler},
                 {"genus", result.topology.genus},
                 {"seconds", seconds},
                 {"mesh", mesh_path}};
}

}  // namespace

const Command kExtractCommand = {
    "extract", "surface mesh from a model's density",
    [] {
      static const std::string text = "--model MODEL --mesh OUT.ply " + surfaceFlagsUsage() + " [--json]";
      return text.c_str();
    }(),
    runExtract};

}  // namespace demnerf::cli
