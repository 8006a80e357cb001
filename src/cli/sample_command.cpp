// `demnerf sample`: a particle cloud (volumes, surface normals and areas) inside a closed mesh,
// by the paper's random, Poisson-disk or uniform-grid sampling (packages/geometry).

#include <algorithm>
#include <chrono>
#include <string>
#include <set>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/particle_sampler.hpp"

#include "demnerf/nerf/model_io.hpp"
#include "pipeline/model_geometry.hpp"
#include "surface_flags.hpp"

namespace demnerf::cli {
namespace {

Figures runSample(const Arguments& arguments) {
  std::set<std::string> known = surfaceFlagNames();  // with --model
  known.insert({"mesh", "model", "method", "spacing", "out", "seed", "weights", "surface-volumes", "json", "quiet"});
  arguments.rejectUnknown(known);
  if (arguments.has("mesh") == arguments.has("model")) throw UsageError("give either --mesh or --model");
  const std::string out_path = arguments.text("out");
  geometry::SamplerConfig config;  // its method and seed are the defaults, as nerf_node's
  config.method = geometry::parseSamplingMethod(arguments.text("method", geometry::samplingMethodName(config.method)));
  config.spacing = arguments.number("spacing");
  const int seed = arguments.integer("seed", static_cast<int>(config.seed));
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
    const nerf::NerfModel model = nerf::loadModel(arguments.text("model"));
    // As `demnerf extract` and nerf_node: the surface as rendered unless --threshold asks for a
    // density iso-surface; with --box only the object inside it.
    mesh = dem_nerf::extractSurface(model, surfaceFlags(arguments)).mesh;
    cloud = geometry::sampleParticles(mesh, config, &report);
    dem_nerf::colourFromModel(model, &cloud);
  }
  core::writeParticles(out_path, cloud);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Figures{{"particles", cloud.size()},       {"surface", report.surface},
                 {"interior", report.interior},     {"volume", report.mesh_volume},
                 {"volume_sum", report.volume_sum}, {"area", report.mesh_area},
                 {"area_sum", report.area_sum},     {"method", geometry::samplingMethodName(config.method)},
                 {"spacing", config.spacing},       {"seconds", seconds},
                 {"crack_walls", report.crack_walls}, {"out", out_path}};
}

}  // namespace

const Command kSampleCommand = {
    "sample", "particles inside a closed mesh",
    [] {
      static const std::string text = "(--mesh M.ply|M.obj | --model MODEL " + surfaceFlagsUsage() +
                                      ") --method random|poisson|grid --spacing H --out P.ply [--seed 1] "
                                      "[--weights voronoi|uniform] [--surface-volumes false] [--json]";
      return text.c_str();
    }(),
    runSample};

}  // namespace demnerf::cli
