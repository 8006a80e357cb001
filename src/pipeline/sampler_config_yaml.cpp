#include "pipeline/sampler_config_yaml.hpp"

#include <limits>

#include "pipeline/yaml_keys.hpp"

namespace dem_nerf {

demnerf::geometry::SamplerConfig parseSamplerConfig(const std::string& yaml_text, const std::string& source,
                                                    demnerf::geometry::SamplerConfig base) {
  demnerf::geometry::SamplerConfig c = base;
  const auto method = [&c](const YAML::Node& node) -> std::string {
    try {
      c.method = demnerf::geometry::parseSamplingMethod(node.as<std::string>());
    } catch (const demnerf::core::Error&) {
      return "must be random, poisson or grid, got '" + YAML::Dump(node) + "'";
    }
    return "";
  };
  const auto weights = [&c](const YAML::Node& node) -> std::string {
    const std::string name = node.as<std::string>();
    if (name == "voronoi") c.volume_weights = demnerf::geometry::VolumeWeights::kVoronoi;
    else if (name == "uniform") c.volume_weights = demnerf::geometry::VolumeWeights::kUniform;
    else return "must be voronoi or uniform, got '" + name + "'";
    return "";
  };
  const auto flag = [](bool* value) {
    return [value](const YAML::Node& node) -> std::string {
      *value = node.as<bool>();
      return "";
    };
  };
  readYamlKeys(yaml_text, source,
               {{"method", method},
                {"spacing", numberAtLeast(&c.spacing, 0.0)},
                {"seed", integerIn(&c.seed, 0, std::numeric_limits<long long>::max())},
                {"weights", weights},
                {"surface_volumes", flag(&c.surface_volumes)}});
  return c;
}

}  // namespace dem_nerf
