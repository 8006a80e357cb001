#include "mechanics_matrix_nerf.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "demnerf/core/dataset.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "demnerf/render/synthetic_scene.hpp"
#include "mechanics_bench_common.hpp"

namespace demnerf::bench {
namespace {

/// Trains until the process has spent `cpu_budget` CPU seconds on steps; the learning-rate schedule
/// decays over the steps expected at the rate measured so far (as nerf_train --cpu-seconds does).
nerf::TrainProgress trainForCpuSeconds(nerf::Trainer& trainer, double cpu_budget) {
  const double start = processCpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  for (double used = 0; used < cpu_budget; used = processCpuSeconds() - start) {
    if (trainer.iteration() > 0 && used > 0) {
      const auto expected = static_cast<std::int64_t>(trainer.iteration() * cpu_budget / used);
      trainer.setBudget({0, std::max<std::int64_t>(1, expected)});
    }
    trainer.step(1);
  }
  nerf::TrainProgress progress;
  progress.iteration = trainer.iteration();
  progress.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return progress;
}

}  // namespace

core::TriangleMesh nerfSurface(const NerfSurfaceConfig& config) {
  namespace fs = std::filesystem;
  const std::string cached = config.work_dir + "/extracted_mesh.ply";
  if (fs::exists(cached)) {
    std::fprintf(stderr, "NeRF %s: cached surface %s\n", config.scene.c_str(), cached.c_str());
    return core::readMesh(cached);
  }
  const std::string data = config.work_dir + "/views";
  if (!fs::exists(data + "/transforms_train.json")) {
    render::SynthConfig synth;  // `demnerf synth --scene S`: 48 views of 200 px
    synth.scene = config.scene;
    synth.out_dir = data;
    const render::SynthFigures made = render::generateSyntheticScene(synth);
    std::fprintf(stderr, "NeRF %s: synthesised %d views in %.1f s\n", config.scene.c_str(), made.views, made.seconds);
  }
  // `demnerf train --seconds S [--config FILE]`.
  const core::Dataset dataset = core::loadDataset(data);
  const nerf::NerfConfig nerf_config =
      config.nerf_config.empty() ? nerf::NerfConfig{} : nerf::loadNerfConfig(config.nerf_config);
  nerf::Trainer trainer(nerf_config, nerf::datasetBox(dataset), dataset.aabb_scale);
  trainer.addFrames(dataset.train);
  nerf::TrainProgress progress;
  if (config.cpu_seconds > 0) {
    progress = trainForCpuSeconds(trainer, config.cpu_seconds);
    std::fprintf(stderr, "NeRF %s: %lld iterations in %.0f CPU s (%.1f s wall)\n", config.scene.c_str(),
                 static_cast<long long>(progress.iteration), config.cpu_seconds, progress.seconds);
  } else {
    nerf::StopCriteria stop;
    stop.seconds = config.seconds;
    progress = trainer.train(stop, {}, false);
    std::fprintf(stderr, "NeRF %s: %lld iterations in %.1f s, train PSNR %.2f dB\n", config.scene.c_str(),
                 static_cast<long long>(progress.iteration), progress.seconds, progress.psnr);
  }
  // `demnerf extract` (opacity 0.15 along the clearest axis), with a face budget.
  const nerf::NerfModel& model = trainer.model();
  const nerf::Box box = model.bounds();
  const Eigen::AlignedBox3d aabb(Eigen::Vector3d(box.min[0], box.min[1], box.min[2]),
                                 Eigen::Vector3d(box.max[0], box.max[1], box.max[2]));
  const geometry::DensityGrid grid = geometry::sampleDensityGrid(
      [&model](const float* points, std::int64_t n, float* sigma) { model.field().density(points, n, sigma); }, aabb,
      config.resolution);
  geometry::MeshExtractionConfig extraction;
  extraction.surface = geometry::SurfaceDefinition::kOpacity;
  extraction.opacity = 0.15;
  extraction.simplification.max_faces = static_cast<std::size_t>(config.max_faces);
  extraction.simplification.fast = true;
  const geometry::MeshExtractionResult result = geometry::extractMesh(grid, extraction);
  std::fprintf(stderr, "NeRF %s: extracted %zu faces, volume %.6g m^3, closed %d\n", config.scene.c_str(),
               result.faces, result.volume, result.closed ? 1 : 0);
  fs::create_directories(config.work_dir);
  nerf::saveModel(model, config.work_dir + "/model.nerf");
  core::writeMesh(cached, result.mesh);
  return result.mesh;
}

}  // namespace demnerf::bench
