#include "ros_params/nerf_parameters.hpp"

#include <string>

#include "pipeline/sampler_config_yaml.hpp"
#include "ros_params/parameters.hpp"
#include "ros_params/parameters_yaml.hpp"
#include "ros_params/renamed_parameters.hpp"

namespace dem_nerf {
namespace {

template <class Node>
demnerf::nerf::NerfConfig nerfConfig(const Node& node) {
  std::string file;
  node.param("nerf_config", file, file);
  demnerf::nerf::NerfConfig config = file.empty() ? demnerf::nerf::NerfConfig{} : demnerf::nerf::loadNerfConfig(file);
  const std::string yaml = namespaceAsYaml(node, "nerf");
  if (!yaml.empty()) config = demnerf::nerf::parseNerfConfig(yaml, "parameter ~nerf", config);
  readCount(node, "threads", config.train.threads, 0);
  config.validate();
  return config;
}

template <class Node>
SurfaceConfig surfaceConfig(const Node& node) {
  rejectRenamed(node, {{"extract_resolution", "~extraction/resolution"},
                       {"surface_opacity", "~extraction/opacity"},
                       {"density_threshold", "~extraction/threshold with ~extraction/surface: density"}});
  const std::string yaml = namespaceAsYaml(node, "extraction");
  return yaml.empty() ? SurfaceConfig{} : parseSurfaceConfig(yaml, "parameter ~extraction");
}

template <class Node>
demnerf::geometry::SamplerConfig samplerConfig(const Node& node) {
  rejectRenamed(node, {{"sampler", "~sampling/method"}, {"particle_spacing", "~sampling/spacing"}});
  const std::string yaml = namespaceAsYaml(node, "sampling");
  // spacing 0: particlesFromModel picks 1/40 of the surface's bounding-box diagonal
  return yaml.empty() ? demnerf::geometry::SamplerConfig{} : parseSamplerConfig(yaml, "parameter ~sampling");
}

}  // namespace

demnerf::nerf::NerfConfig readNerfParameters(const ros::NodeHandle& node) { return nerfConfig(node); }
demnerf::nerf::NerfConfig readNerfParameters(const ParameterMap& node) { return nerfConfig(node); }
SurfaceConfig readSurfaceParameters(const ros::NodeHandle& node) { return surfaceConfig(node); }
SurfaceConfig readSurfaceParameters(const ParameterMap& node) { return surfaceConfig(node); }
demnerf::geometry::SamplerConfig readSamplerParameters(const ros::NodeHandle& node) { return samplerConfig(node); }
demnerf::geometry::SamplerConfig readSamplerParameters(const ParameterMap& node) { return samplerConfig(node); }

}  // namespace dem_nerf
