#include "pipeline/surface_config.hpp"

#include <limits>

#include "pipeline/yaml_keys.hpp"

namespace dem_nerf {
namespace {

using Reader = std::function<std::string(const YAML::Node&)>;

Reader surfaceKind(demnerf::geometry::MeshExtractionConfig* mesh) {
  return [=](const YAML::Node& node) -> std::string {
    try {
      mesh->surface = demnerf::geometry::parseSurfaceDefinition(node.as<std::string>());
    } catch (const demnerf::core::Error&) {
      return "must be opacity or density, got '" + YAML::Dump(node) + "'";
    }
    return "";
  };
}

Reader opacityIn01(double* opacity) {
  return [=](const YAML::Node& node) -> std::string {
    const double v = node.as<double>();
    if (!(v > 0.0 && v < 1.0)) return "must lie in (0, 1), got " + YAML::Dump(node);
    *opacity = v;
    return "";
  };
}

Reader boxOf(std::optional<Eigen::AlignedBox3d>* box) {
  return [=](const YAML::Node& node) -> std::string {
    if (!node.IsSequence() || node.size() != 6) return "must be [xmin, ymin, zmin, xmax, ymax, zmax]";
    std::string text;
    for (std::size_t i = 0; i < 6; ++i) text += (i ? "," : "") + node[i].as<std::string>();
    try {
      *box = demnerf::geometry::parseBox(text);  // finite numbers, min < max on every axis
    } catch (const demnerf::core::Error& error) {
      return error.what();
    }
    return "";
  };
}

Reader directionOf(Eigen::Vector3d* direction) {
  return [=](const YAML::Node& node) -> std::string {
    if (!node.IsSequence() || node.size() != 3) return "must be [dx, dy, dz] (towards the cameras; [0, 0, 0]: off)";
    const Eigen::Vector3d d(node[0].as<double>(), node[1].as<double>(), node[2].as<double>());
    if (!d.allFinite()) return "must be finite, got " + YAML::Dump(node);
    *direction = d;
    return "";
  };
}

}  // namespace

SurfaceConfig parseSurfaceConfig(const std::string& yaml_text, const std::string& source, SurfaceConfig base) {
  SurfaceConfig c = std::move(base);
  const long long no_limit = std::numeric_limits<int>::max();
  readYamlKeys(yaml_text, source,
               {{"resolution", integerIn(&c.resolution, 8, 1024)},
                {"surface", surfaceKind(&c.mesh)},
                {"opacity", opacityIn01(&c.mesh.opacity)},
                {"threshold", numberAtLeast(&c.mesh.threshold, 0.0, true)},
                {"max_faces", integerIn(&c.mesh.simplification.max_faces, 0, no_limit)},
                {"smoothing", integerIn(&c.mesh.repair.smoothing_iterations, 0, 1000)},
                {"box", boxOf(&c.box)},
                {"max_second_piece", numberAtLeast(&c.isolation.max_second_piece_fraction, 0.0, true)},
                {"solid_radius", numberAtLeast(&c.mesh.solid.radius, 0.0)},
                {"solid_behind", directionOf(&c.mesh.solid.behind)},
                {"solid_views", integerIn(&c.solid_views, 0, no_limit)}});
  if (c.solid_views > 0 && c.mesh.solid.radius == 0.0) {
    throw demnerf::core::Error(source + ": 'solid_views' needs 'solid_radius' > 0 as well: the closing shuts the "
                               "slits grazing views leave in the carved fill (the fox: solid_radius 0.16, "
                               "solid_views 4, in the scene's units)");
  }
  if (c.solid_views > 0 && c.mesh.solid.behind != Eigen::Vector3d::Zero()) {
    throw demnerf::core::Error(source + ": 'solid_views' (space carving against the training cameras) and "
                               "'solid_behind' are alternatives; give one (solid_views is the tighter fill)");
  }
  return c;
}

SurfaceConfig withTrainingCameras(SurfaceConfig config, const std::vector<demnerf::core::Frame>& frames,
                                  const std::string& origin) {
  if (config.solid_views <= 0) return config;
  const std::string views = "space carving (solid_views " + std::to_string(config.solid_views) + ")";
  if (frames.empty())
    throw demnerf::core::Error(views + " needs the cameras the model trained on, and there are none in " + origin);
  if (static_cast<std::size_t>(config.solid_views) > frames.size()) {
    throw demnerf::core::Error(views + " needs that many of the cameras the model trained on, and there are only " +
                               std::to_string(frames.size()) + " in " + origin + ": give at most " +
                               std::to_string(frames.size()));
  }
  config.mesh.solid.cameras.clear();
  for (const demnerf::core::Frame& frame : frames) config.mesh.solid.cameras.push_back({frame.camera, frame.world_from_camera});
  config.mesh.solid.min_views = config.solid_views;
  return config;
}

}  // namespace dem_nerf
