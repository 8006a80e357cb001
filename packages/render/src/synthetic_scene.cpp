#include "demnerf/render/synthetic_scene.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/render/camera_rig.hpp"
#include "demnerf/render/mesh_renderer.hpp"

namespace demnerf::render {
namespace {

void validateConfig(const SynthConfig& config) {
  if (config.views < 1) {
    throw core::Error("synthetic scene: --views must be at least 1, got " + std::to_string(config.views));
  }
  if (config.test_views < 0) {
    throw core::Error("synthetic scene: --test-views must not be negative, got " + std::to_string(config.test_views));
  }
  if (config.views + config.test_views > 100000) {
    throw core::Error("synthetic scene: " + std::to_string(config.views + config.test_views) + " views are too many (at most 100000)");
  }
  if (config.size < 8 || config.size > 8192) {
    throw core::Error("synthetic scene: --size must be in 8..8192 pixels, got " + std::to_string(config.size));
  }
  if (config.out_dir.empty()) throw core::Error("synthetic scene: no output directory given (--out DIR)");
  if (config.samples_per_axis < 1 || config.samples_per_axis > 16) {
    throw core::Error("synthetic scene: samples per axis must be in 1..16, got " + std::to_string(config.samples_per_axis));
  }
  if (!config.particles_path.empty() && config.result_path.empty()) {
    throw core::Error("synthetic scene: a particle file ('" + config.particles_path + "') only makes sense with --result");
  }
}

core::ResultField loadResult(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw core::Error("synthetic scene: cannot read the result file '" + path + "': no such file");
  }
  try {
    core::ResultField result = core::readResult(path);
    result.validate();
    if (result.size() == 0) throw core::Error("it holds no particles");
    return result;
  } catch (const std::exception& error) {
    throw core::Error("synthetic scene: cannot use the result file '" + path + "': " + error.what());
  }
}

// The result must be for the particles the user says it was computed on.
void checkParticleCount(const core::ResultField& result, const SynthConfig& config) {
  if (config.particles_path.empty()) return;
  core::ParticleCloud cloud;
  try {
    cloud = core::readParticles(config.particles_path);
  } catch (const std::exception& error) {
    throw core::Error("synthetic scene: cannot read the particle file '" + config.particles_path + "': " + error.what());
  }
  if (cloud.size() != result.size()) {
    throw core::Error("synthetic scene: the result '" + config.result_path + "' has " + std::to_string(result.size()) +
                      " particles but the particle file '" + config.particles_path + "' has " +
                      std::to_string(cloud.size()) + "; they must be one row per particle, in order");
  }
}

// Every particle must lie near the body: a result for another object or frame is refused.
void checkParticlesNearBody(const core::ResultField& result, const Eigen::AlignedBox3d& bounds, double reach,
                            const std::string& scene) {
  const Eigen::AlignedBox3d grown(bounds.min().array() - reach, bounds.max().array() + reach);
  for (std::size_t i = 0; i < result.size(); ++i) {
    if (!grown.contains(result.positions[i])) {
      const auto& p = result.positions[i];
      std::ostringstream message;
      message << "synthetic scene: result particle " << i << " at (" << p.x() << ", " << p.y() << ", " << p.z()
              << ") lies outside the " << scene << " (box (" << bounds.min().transpose() << ") .. ("
              << bounds.max().transpose() << ") m): is the result for another scene?";
      throw core::Error(message.str());
    }
  }
}

std::vector<core::Frame> renderSplit(const MeshRenderer& renderer, const CameraRig& rig,
                                     const std::vector<Eigen::Isometry3d>& poses, const std::string& split,
                                     const std::filesystem::path& root, const RenderConfig& render_config) {
  std::filesystem::create_directories(root / split);
  std::vector<core::Frame> frames;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "r_%03zu.png", i);
    core::Frame frame;
    frame.file_path = split + "/" + name;
    frame.camera = rig.camera;
    frame.world_from_camera = poses[i];
    frame.has_alpha = true;
    const cv::Mat image = renderer.render(rig.camera, poses[i], render_config);
    core::writeImagePng((root / frame.file_path).string(), image);
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace

SurfaceShader makeSceneShader(const SceneObject& object, std::uint64_t seed) {
  ShadingConfig shading;
  shading.base_color = object.base_color;
  SpeckleConfig speckle;
  speckle.cell = object.speckle_cell;
  speckle.seed = hashMix(seed, 0x5bec1e);
  return SurfaceShader(shading, speckle);
}

SynthFigures generateSyntheticScene(const SynthConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  validateConfig(config);
  const SceneKind kind = parseSceneKind(config.scene);
  const SceneObject object = makeSceneObject(kind, config.mesh_edge);

  SynthFigures figures;
  figures.scene = sceneName(kind);
  core::TriangleMesh shown = object.mesh;
  if (!config.result_path.empty()) {
    const core::ResultField result = loadResult(config.result_path);
    checkParticleCount(result, config);
    const DisplacementInterpolator field(result.positions, result.displacements, config.interpolation);
    checkParticlesNearBody(result, object.bounds, config.interpolation.coverage_factor * field.typicalSpacing(),
                           figures.scene);
    figures.max_vertex_to_particle = field.checkCovers(object.mesh.vertices, "the " + figures.scene + " mesh");
    shown = deformMesh(object.mesh, field);
    figures.deformed = true;
    figures.result_particles = result.size();
    figures.particle_spacing = field.typicalSpacing();
    for (std::size_t i = 0; i < shown.vertices.size(); ++i) {
      figures.max_displacement = std::max(figures.max_displacement, (shown.vertices[i] - object.mesh.vertices[i]).norm());
    }
  }

  CameraRigConfig rig_config;
  rig_config.train_views = config.views;
  rig_config.test_views = config.test_views;
  rig_config.width = rig_config.height = config.size;
  rig_config.fov_x_degrees = config.fov_degrees;
  // Cameras depend on the rest shape only, so deformed ground truth shares the rest dataset's.
  const CameraRig rig = makeCameraRig(object.bounds, rig_config);

  const MeshRenderer renderer(object.mesh, shown, makeSceneShader(object, config.seed));
  RenderConfig render_config;
  render_config.samples_per_axis = config.samples_per_axis;
  render_config.threads = config.threads;
  render_config.seed = config.seed;

  const std::filesystem::path root(config.out_dir);
  try {
    std::filesystem::create_directories(root);
  } catch (const std::exception& error) {
    throw core::Error("synthetic scene: cannot create the output directory '" + config.out_dir + "': " + error.what());
  }
  // The scene box for NeRF: the body (rest and deformed) with 10 % of its diagonal around it.
  Eigen::AlignedBox3d bounds = object.bounds;
  for (const auto& v : shown.vertices) bounds.extend(v);
  const double pad = 0.1 * bounds.diagonal().norm();
  bounds = Eigen::AlignedBox3d(bounds.min().array() - pad, bounds.max().array() + pad);

  const auto train = renderSplit(renderer, rig, rig.train, "train", root, render_config);
  core::writeTransforms((root / "transforms_train.json").string(), train, bounds);
  if (config.test_views > 0) {
    const auto test = renderSplit(renderer, rig, rig.test, "test", root, render_config);
    core::writeTransforms((root / "transforms_test.json").string(), test, bounds);
  }
  core::writeMesh((root / "mesh.ply").string(), shown);
  if (figures.deformed) core::writeMesh((root / "rest_mesh.ply").string(), object.mesh);

  figures.views = config.views;
  figures.test_views = config.test_views;
  figures.width = figures.height = config.size;
  figures.vertices = shown.vertices.size();
  figures.faces = shown.faces.size();
  figures.camera_distance = rig.distance;
  figures.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return figures;
}

}  // namespace demnerf::render
