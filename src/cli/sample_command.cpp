// `demnerf sample`: a particle cloud (volumes, surface normals and areas) inside a closed mesh,
// by the paper's random, Poisson-disk or uniform-grid sampling (packages/geometry).

#include <chrono>

#include <algorithm>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/particle_sampler.hpp"

#if __has_include("demnerf/nerf/model_io.hpp")
#include "demnerf/nerf/model_io.hpp"
#define DEMNERF_SAMPLE_HAS_NERF 1
#endif

namespace demnerf::cli {
namespace {

#ifdef DEMNERF_SAMPLE_HAS_NERF
// The NeRF's surface (as `demnerf extract` makes it) and its colour at each particle, seen
// from outside along the particle's normal (interior particles: from above).
core::TriangleMesh meshFromModel(const nerf::NerfModel& model, int resolution, double threshold) {
  geometry::DensityGrid grid;
  grid.dims = Eigen::Vector3i::Constant(resolution);
  const nerf::Box box = model.bounds();
  for (int a = 0; a < 3; ++a) {
    grid.spacing[a] = static_cast<double>(box.size(a)) / resolution;
    grid.origin[a] = box.min[a] + 0.5 * grid.spacing[a];
  }
  grid.values = model.densityGrid(resolution);
  geometry::MeshExtractionConfig config;
  config.threshold = threshold;
  return geometry::extractMesh(grid, config).mesh;
}

void colourFromModel(const nerf::NerfModel& model, core::ParticleCloud* cloud) {
  const std::size_t n = cloud->size();
  std::vector<float> points(3 * n), directions(3 * n), sigma(n), rgb(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d view = cloud->isSurface(i) ? Eigen::Vector3d(-cloud->normals[i]) : Eigen::Vector3d(0, 0, -1);
    for (int a = 0; a < 3; ++a) {
      points[3 * i + a] = static_cast<float>(cloud->positions[i][a]);
      directions[3 * i + a] = static_cast<float>(view[a]);
    }
  }
  model.field().query(points.data(), directions.data(), static_cast<std::int64_t>(n), sigma.data(), rgb.data());
  for (std::size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = std::min(1.0f, std::max(0.0f, rgb[3 * i + c]));
      cloud->colors[i][c] = static_cast<std::uint8_t>(v * 255.0f + 0.5f);
    }
  }
}
#endif

Figures runSample(const Arguments& arguments) {
  arguments.rejectUnknown({"mesh", "model", "resolution", "threshold", "method", "spacing", "out", "seed", "weights",
                           "surface-volumes", "json", "quiet"});
  if (arguments.has("mesh") == arguments.has("model")) throw UsageError("give either --mesh or --model");
  const std::string out_path = arguments.text("out");
  geometry::SamplerConfig config;
  config.method = geometry::parseSamplingMethod(arguments.text("method", "poisson"));
  config.spacing = arguments.number("spacing");
  const int seed = arguments.integer("seed", 1);
  if (seed < 0) throw UsageError("option --seed expects a non-negative integer, got " + std::to_string(seed));
  config.seed = static_cast<std::uint64_t>(seed);
  const std::string weights = arguments.text("weights", "voronoi");
  if (weights == "uniform") config.volume_weights = geometry::VolumeWeights::kUniform;
  else if (weights != "voronoi") throw UsageError("option --weights expects voronoi or uniform, got '" + weights + "'");
  const std::string surface_volumes = arguments.text("surface-volumes", "false");
  if (surface_volumes != "true" && surface_volumes != "false") {
    throw UsageError("option --surface-volumes expects true or false, got '" + surface_volumes + "'");
  }
  config.surface_volumes = surface_volumes == "true";

  const auto start = std::chrono::steady_clock::now();
  core::TriangleMesh mesh;
  core::ParticleCloud cloud;
  geometry::SamplingReport report;
  if (arguments.has("mesh")) {
    mesh = core::readMesh(arguments.text("mesh"));
    cloud = geometry::sampleParticles(mesh, config, &report);
  } else {
#ifdef DEMNERF_SAMPLE_HAS_NERF
    const nerf::NerfModel model = nerf::loadModel(arguments.text("model"));
    mesh = meshFromModel(model, arguments.integer("resolution", 256), arguments.number("threshold", 2.5));
    cloud = geometry::sampleParticles(mesh, config, &report);
    colourFromModel(model, &cloud);
#else
    throw NotBuiltYet("demnerf sample --model needs the NeRF library (packages/nerf), which is not built yet in this build");
#endif
  }
  core::writeParticles(out_path, cloud);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Figures{{"particles", cloud.size()},       {"surface", report.surface},
                 {"interior", report.interior},     {"volume", report.mesh_volume},
                 {"volume_sum", report.volume_sum}, {"area", report.mesh_area},
                 {"area_sum", report.area_sum},     {"method", geometry::samplingMethodName(config.method)},
                 {"spacing", config.spacing},       {"seconds", seconds},
                 {"out", out_path}};
}

}  // namespace

const Command kSampleCommand = {
    "sample", "particles inside a closed mesh",
    "(--mesh M.ply|M.obj | --model MODEL [--resolution 256] [--threshold 2.5]) --method random|poisson|grid "
    "--spacing H --out P.ply [--seed 1] "
    "[--weights voronoi|uniform] [--surface-volumes false] [--json]",
    runSample};

}  // namespace demnerf::cli
