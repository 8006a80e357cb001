#include "nodes/nerf/nerf_node_config.hpp"

#include <cstdlib>

#include "ros_params/nerf_parameters.hpp"
#include "ros_params/parameters.hpp"

namespace dem_nerf {
namespace {

template <class Node>
NerfNodeConfig read(const Node& node) {
  NerfNodeConfig config;
  node.param("cameras", config.cameras, config.cameras);
  if (config.cameras.empty()) throw demnerf::core::Error("parameter ~cameras must name at least one camera namespace");
  node.param("world_frame", config.world_frame, config.world_frame);
  readNumber(node, "tf_timeout", config.tf_timeout, 0.0);
  readNumber(node, "min_translation", config.min_translation, 0.0);
  readNumber(node, "min_rotation", config.min_rotation, 0.0);
  readCount(node, "max_frames", config.max_frames, 1);
  readCount(node, "min_frames", config.min_frames, 1);
  readCount(node, "max_image_size", config.max_image_size, 16);
  readCount(node, "max_input_pixels", config.max_input_pixels, 1);
  readCount(node, "max_render_pixels", config.max_render_pixels, 1);
  config.aabb = readList(node, "aabb", 6);
  if (!config.aabb.empty() && (config.aabb[3] <= config.aabb[0] || config.aabb[4] <= config.aabb[1] ||
                               config.aabb[5] <= config.aabb[2])) {
    throw demnerf::core::Error("parameter ~aabb must be [xmin, ymin, zmin, xmax, ymax, zmax] with min < max");
  }
  config.background_color = readList(node, "background_color", 3);
  readNumber(node, "key_tolerance", config.key_tolerance, 0.0);
  readNumber(node, "train_seconds", config.train_seconds, 0.0);
  readCount(node, "max_iterations", config.max_iterations, 0);
  readNumber(node, "autosave_seconds", config.autosave_seconds, 0.0);
  node.param("model_path", config.model_path, config.model_path);
  config.nerf = readNerfParameters(node);
  config.extraction = readSurfaceParameters(node);
  config.sampling = readSamplerParameters(node);
  if (config.model_path.empty()) {
    // Autosave somewhere even when nobody chose a path: a restart should not lose the training.
    const char* ros_home = std::getenv("ROS_HOME");
    const char* home = std::getenv("HOME");
    config.model_path = std::string(ros_home ? ros_home : std::string(home ? home : "/tmp") + "/.ros") +
                        "/dem_nerf_model.nerf";
  }
  if (config.min_frames > config.max_frames) {
    throw demnerf::core::Error("parameter ~min_frames must not exceed ~max_frames");
  }
  if (config.extraction.solid_views > config.max_frames) {
    // Carving counts views among the keyframes (withTrainingCameras), of which at most ~max_frames are kept.
    throw demnerf::core::Error("parameter ~extraction/solid_views (" + std::to_string(config.extraction.solid_views) +
                               ") must not exceed ~max_frames (" + std::to_string(config.max_frames) +
                               "): space carving counts views among the keyframes kept");
  }
  return config;
}

}  // namespace

NerfNodeConfig NerfNodeConfig::fromParameters(const ros::NodeHandle& node) { return read(node); }

NerfNodeConfig NerfNodeConfig::fromParameters(const ParameterMap& parameters) { return read(parameters); }

FrameIntakeConfig NerfNodeConfig::intake() const {
  FrameIntakeConfig intake;
  intake.world_frame = world_frame;
  intake.tf_timeout = tf_timeout;
  intake.max_image_size = max_image_size;
  intake.max_input_pixels = static_cast<std::uint64_t>(max_input_pixels);
  intake.keyframes.min_translation = min_translation;
  intake.keyframes.min_rotation_degrees = min_rotation;
  intake.keyframes.max_frames = static_cast<std::size_t>(max_frames);
  if (!background_color.empty()) {
    demnerf::core::ColourKey key;
    key.color = cv::Vec3f(background_color[0], background_color[1], background_color[2]);
    key.tolerance = key_tolerance;
    intake.colour_key = key;
  }
  return intake;
}

}  // namespace dem_nerf
