// Does Taubin smoothing bring a NeRF extraction closer to the true body, or only make it smoother?
// One saved model, the product's extraction (dem_nerf::extractSurface, opacity 0.15, the matrix's
// face budget) at several smoothing counts, each against the exact surface `demnerf synth` writes:
// Chamfer (mean of both directions), the 95th / 99th percentile of the pooled point-to-surface
// distances, Hausdorff, volume and area errors, and, per matrix cloud (the matrix's samplers and
// spacings), whether the default DEM still calls the surface rough (dem.grid.rough_surface: the
// surface particles' scatter about their local quadric over that radius, dem_config_check.cpp).
//
//   nerf_extraction_smoothing --model M.nerf --truth VIEWS/mesh.ply --scenario tbar_twist
//       [--smooth 0,2,5,10] [--resolution 192] [--max-faces 20000] [--samplers random,poisson,grid]
//       [--spacings 6,10,15] [--out DIR: writes DIR/extracted_smooth<N>.ply]
//       [--mu -0.53: Taubin's inflating step; other values run the same passes with that step, a
//        filter that reaches longer bumps, outside the product (MeshRepairConfig has counts only)]
//       [--rounded R: a control without NeRF noise: instead of the model, the exact body grown by
//        R m (flat faces, edges rounded to radius R) through the same extraction, and its closing
//        with --solid-radius]
//       [any other of `demnerf extract`'s surface flags, read and checked by its own parser: e.g.
//        --opacity 0.15 (others tell where the density edge lies, e.g. on a field trained with
//        train.distortion), --threshold T (a density surface instead), --solid-radius R (m),
//        --solid-cameras VIEWS --solid-views N (space carving against VIEWS' training cameras)]
// Each row also gives the extraction's CPU-s (the process's, all threads) and what the solid
// step filled. (docs/mechanics_matrix_nerf.md, "A smoothed extraction" and "Extraction settings
// and the body they give").

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstdio>
#include <ctime>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/mesh_distance.hpp"
#include "demnerf/geometry/mesh_simplification.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "cli/arguments.hpp"
#include "cli/surface_flags.hpp"
#include "dem_config_check.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_report.hpp"
#include "pipeline/model_geometry.hpp"
#include "surface_roughness.hpp"

using namespace demnerf;
namespace dm = demnerf::mechanics;

namespace {

using Options = std::map<std::string, std::string>;

Options parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key.rfind("--", 0) != 0 || i + 1 >= argc) throw std::runtime_error("bad argument " + key);
    options[key.substr(2)] = argv[++i];
  }
  return options;
}

std::string get(const Options& o, const std::string& key, const std::string& fallback) {
  const auto it = o.find(key);
  return it == o.end() ? fallback : it->second;
}

double percentile(std::vector<double> values, double share) {
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(share * (values.size() - 1))];
}

// Point-to-surface distances both ways, pooled: the tail a mean Chamfer hides (a rounded edge,
// a bump) shows in the high percentiles.
struct Deviation {
  double chamfer = 0.0, p95 = 0.0, p99 = 0.0, hausdorff = 0.0;
};

Deviation deviation(const core::TriangleMesh& mesh, const core::TriangleMesh& truth) {
  const geometry::MeshDistance d = geometry::meshDistance(mesh, truth);
  std::vector<double> pooled = geometry::distancesToMesh(truth, geometry::sampleSurfacePoints(mesh, 20000, 3));
  const std::vector<double> back = geometry::distancesToMesh(mesh, geometry::sampleSurfacePoints(truth, 20000, 4));
  pooled.insert(pooled.end(), back.begin(), back.end());
  return {d.chamfer, percentile(pooled, 0.95), percentile(pooled, 0.99), d.hausdorff};
}

// The default DEM's verdict on one cloud: the rough rule's measure over its radius (the body
// cell's two cells, at least three surface spacings) in % of that radius, "R" past the rule's
// share, and "finer" when the cell it resolves to is finer than with the rule off (a cloud with
// fewer particles than body_cells keeps its cell however rough).
std::string roughVerdict(const core::ParticleCloud& cloud) {
  dm::DemConfig off;
  off.grid.rough_surface = 0.0;
  const double body_cell = dm::resolvedDemConfig(off, cloud).config.grid.cell;
  const dm::DemConfig defaults;
  const double cell = dm::resolvedDemConfig(defaults, cloud).config.grid.cell;
  const double radius = std::max(2 * body_cell, 3 * dm::surfaceParticleSpacing(cloud));
  const double share = dm::surfaceRoughness(cloud, radius) / radius;
  char text[96];
  std::snprintf(text, sizeof(text), "%.2f%%%s%s", 100 * share, share > defaults.grid.rough_surface ? " R" : "",
                cell < body_cell * (1 - 1e-9) ? " finer" : "");
  return text;
}

void printRoughness(const core::TriangleMesh& mesh, const bench::MatrixCase& mc, const Options& options) {
  for (const std::string& sampler : bench::splitList(get(options, "samplers", "random,poisson,grid"))) {
    std::printf("    %-8s", sampler.c_str());
    for (const std::string& divisor : bench::splitList(get(options, "spacings", "6,10,15"))) {
      geometry::SamplerConfig config;
      config.method = geometry::parseSamplingMethod(sampler);
      config.spacing = mc.smallest / std::stod(divisor);
      config.seed = 1;  // the matrix's seed
      std::printf("  1/%s %-15s", divisor.c_str(), roughVerdict(geometry::sampleParticles(mesh, config)).c_str());
    }
    std::printf("\n");
  }
}

// The product's SurfaceConfig from `demnerf extract`'s own flags and checks (cli::surfaceFlags,
// --solid-cameras loading the training split as the CLI does). --smooth is this bench's list of
// pass counts and --max-faces its own default (20000), both set per extraction below.
dem_nerf::SurfaceConfig surfaceSettings(const Options& options) {
  std::vector<std::string> tokens;
  for (const auto& [key, value] : options)
    if (key != "smooth" && cli::surfaceFlagNames().count(key)) tokens.insert(tokens.end(), {"--" + key, value});
  return cli::surfaceFlags(cli::Arguments(tokens, {}));
}

// The product's extraction with `passes` Taubin passes; with --mu, the same order (repair, smooth,
// then the face budget) with that inflating step instead of MeshRepairConfig's.
geometry::MeshExtractionResult extraction(const nerf::NerfModel& model, int passes, const Options& options,
                                          dem_nerf::SurfaceConfig config) {
  config.mesh.simplification.max_faces = std::stoul(get(options, "max-faces", "20000"));
  config.mesh.repair.smoothing_iterations = passes;
  if (!options.count("mu")) return dem_nerf::extractSurface(model, config);
  const geometry::MeshSimplificationConfig budget = config.mesh.simplification;
  config.mesh.simplification.max_faces = 0;
  config.mesh.repair.smoothing_iterations = 0;
  geometry::MeshExtractionResult result = dem_nerf::extractSurface(model, config);
  geometry::SmoothingConfig smoothing;
  smoothing.iterations = passes;
  smoothing.mu = std::stod(options.at("mu"));
  result.mesh = geometry::simplifyMesh(geometry::smoothMesh(result.mesh, smoothing), budget);
  const geometry::MeshSummary summary = geometry::analyzeMesh(result.mesh);
  result.faces = summary.faces;
  result.volume = summary.volume();
  result.area = summary.area;
  return result;
}

// The control's surface: the level set {signed distance = R} of the exact body, sampled like the
// model (192 cells along the longest side of its box grown by 30 %) and cut as a density surface.
geometry::MeshExtractionResult roundedBody(const core::TriangleMesh& truth, int passes, const Options& options) {
  const geometry::InsideTest body(truth);
  const geometry::DensityFunction field = [&body](const float* p, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d q(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
      const double d = std::sqrt(body.squaredDistance(q));
      sigma[i] = static_cast<float>(body.inside(q) ? d : -d);  // inside positive, as a density
    }
  };
  Eigen::AlignedBox3d box = geometry::analyzeMesh(truth).bounds;
  const Eigen::Vector3d margin = 0.15 * box.sizes();
  box.extend(box.min() - margin), box.extend(box.max() + margin);
  geometry::MeshExtractionConfig config;
  config.threshold = -std::stod(options.at("rounded"));
  config.solid.radius = std::stod(get(options, "solid-radius", "0"));  // what the closing does to a true body
  config.repair.smoothing_iterations = passes;
  config.simplification.max_faces = std::stoul(get(options, "max-faces", "20000"));
  config.simplification.fast = true;
  return geometry::extractMesh(geometry::sampleDensityGrid(field, box, std::stoi(get(options, "resolution", "192"))),
                               config);
}

const bench::MatrixCase& findCase(const std::string& name) {
  static const std::vector<bench::MatrixCase> cases = bench::matrixCases();
  for (const auto& mc : cases)
    if (mc.name == name) return mc;
  throw std::runtime_error("unknown scenario '" + name + "'");
}

}  // namespace

int main(int argc, char** argv) try {
  const Options options = parse(argc, argv);
  if (!options.count("truth") || !(options.count("model") || options.count("rounded")))
    throw std::runtime_error("needs --truth and --model (or --rounded)");
  std::unique_ptr<nerf::NerfModel> model;
  if (options.count("model")) model = std::make_unique<nerf::NerfModel>(nerf::loadModel(options.at("model")));
  const core::TriangleMesh truth = core::readMesh(options.at("truth"));
  const geometry::MeshSummary exact = geometry::analyzeMesh(truth);
  const bench::MatrixCase& mc = findCase(get(options, "scenario", "tbar_twist"));
  const dem_nerf::SurfaceConfig surface = surfaceSettings(options);  // once: --solid-cameras loads a dataset
  std::printf("exact surface: volume %.6g m^3, area %.5g m^2; rough rule: scatter > %.2f%% of the radius\n",
              exact.volume(), exact.area, 100 * dm::DemConfig{}.grid.rough_surface);
  std::printf("%6s %7s %8s %8s %8s %8s %8s %9s %6s\n", "smooth", "faces", "vol err", "area err", "chamfer", "p95",
              "p99", "hausdorff", "cpu-s");
  for (const std::string& passes : bench::splitList(get(options, "smooth", "0,2,5,10"))) {
    const std::clock_t start = std::clock();
    const geometry::MeshExtractionResult result = options.count("rounded")
                                                      ? roundedBody(truth, std::stoi(passes), options)
                                                      : extraction(*model, std::stoi(passes), options, surface);
    const double cpu_seconds = static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
    const Deviation d = deviation(result.mesh, truth);
    std::printf("%6s %7zu %+7.2f%% %+7.2f%% %6.3fmm %6.2fmm %6.2fmm %7.2fmm %6.1f\n", passes.c_str(), result.faces,
                100 * (result.volume / exact.volume() - 1), 100 * (result.area / exact.area - 1), 1e3 * d.chamfer,
                1e3 * d.p95, 1e3 * d.p99, 1e3 * d.hausdorff, cpu_seconds);
    const geometry::SolidReport& solid = result.solid;
    std::printf("    genus %lld; solid fill (closing radius %.1f cells): %zu nodes closed, %zu carved (%zu in no "
                "image), %zu cavity\n", result.topology.genus, solid.radius_cells, solid.closed_nodes,
                solid.hidden_nodes, solid.unseen_nodes, solid.cavity_nodes);
    if (options.count("out")) core::writeMesh(options.at("out") + "/extracted_smooth" + passes + ".ply", result.mesh);
    printRoughness(result.mesh, mc, options);
    std::fflush(stdout);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "nerf_extraction_smoothing: %s\n", e.what());
  return 1;
}
