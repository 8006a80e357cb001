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
                {"solid_behind", directionOf(&c.mesh.solid.behind)}});
  return c;
}

}  // namespace dem_nerf
