// NeRF-trained T-bar -> surface mesh, against the exact T-bar (issue 5's test, as a benchmark:
// training takes ~60 s, too long for `make test`). Prints, for each surface definition, the
// extracted volume against 0.30*0.06*0.06 + 0.06*0.06*0.24 m^3, the symmetric Chamfer distance
// against the bounding-box diagonal, face counts and times; also how often the density inside
// tests agree with the exact body.
//
//   geometry_tbar_extraction [--model M.nerf --truth mesh.ply | --data DIR] [--seconds 60]
//       [--resolution 256] [--max-faces 200000] [--work DIR] [--save-model M.nerf] [--repeat 3]
//       [--thresholds 2.5,10,30] [--opacities 0.1,0.15,0.2,0.5] [--probe 1 (density along lines, misses by face)]
// Without --model or --data it synthesises the T-bar (render::generateSyntheticScene, 48 views,
// 200 px) into --work and trains on it. The last stdout line is JSON.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_inside_test.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/inside_test.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/mesh_distance.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/optical_depth.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "demnerf/render/synthetic_scene.hpp"

using namespace demnerf;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kExactVolume = 0.30 * 0.06 * 0.06 + 0.06 * 0.06 * 0.24;

double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::map<std::string, std::string> parse(int argc, char** argv) {
  std::map<std::string, std::string> options;
  for (int i = 1; i < argc; ++i) {
    std::string key = argv[i];
    if (key.rfind("--", 0) != 0 || i + 1 >= argc) throw std::runtime_error("bad argument " + key);
    options[key.substr(2)] = argv[++i];
  }
  return options;
}

std::string get(const std::map<std::string, std::string>& o, const std::string& key, const std::string& fallback) {
  const auto it = o.find(key);
  return it == o.end() ? fallback : it->second;
}

}  // namespace

int main(int argc, char** argv) try {
  const auto options = parse(argc, argv);
  const std::string work = get(options, "work", "/tmp/geometry_tbar");
  const int resolution = std::stoi(get(options, "resolution", "256"));
  const std::size_t max_faces = std::stoul(get(options, "max-faces", "200000"));
  const int repeat = std::stoi(get(options, "repeat", "1"));
  nlohmann::json figures;

  std::string truth_path = get(options, "truth", "");
  std::unique_ptr<nerf::NerfModel> model;
  if (options.count("model")) {
    model = std::make_unique<nerf::NerfModel>(nerf::loadModel(options.at("model")));
  } else {
    std::string data = get(options, "data", "");
    if (data.empty()) {
      render::SynthConfig synth;
      synth.scene = "tbar";
      synth.out_dir = data = work + "/tbar";
      const auto made = render::generateSyntheticScene(synth);
      std::fprintf(stderr, "synthesised %s in %.1f s\n", data.c_str(), made.seconds);
    }
    if (truth_path.empty()) truth_path = data + "/mesh.ply";
    const core::Dataset dataset = core::loadDataset(data);
    nerf::NerfConfig config;
    nerf::Trainer trainer(config, nerf::datasetBox(dataset), dataset.aabb_scale);
    trainer.addFrames(dataset.train);
    nerf::StopCriteria stop;
    stop.seconds = std::stod(get(options, "seconds", "60"));
    const auto progress = trainer.train(stop, {}, false);
    std::fprintf(stderr, "trained %lld iterations in %.1f s, train PSNR %.2f dB\n",
                 static_cast<long long>(progress.iteration), progress.seconds, progress.psnr);
    figures["train_seconds"] = progress.seconds;
    figures["train_psnr"] = progress.psnr;
    model = std::make_unique<nerf::NerfModel>(trainer.snapshot());
    if (options.count("save-model")) nerf::saveModel(*model, options.at("save-model"));
  }
  if (truth_path.empty()) throw std::runtime_error("--model needs --truth mesh.ply (the synth output's mesh.ply)");
  const core::TriangleMesh truth = core::readMesh(truth_path);
  const geometry::MeshSummary truth_summary = geometry::analyzeMesh(truth);
  const double diagonal = truth_summary.bounds.diagonal().norm();
  std::printf("exact T-bar: volume %.6g m^3 (mesh %.6g), area %.5g m^2, bbox diagonal %.4f m\n", kExactVolume,
              truth_summary.volume(), truth_summary.area, diagonal);

  const nerf::NerfModel& nerf_model = *model;
  const geometry::DensityFunction density = [&nerf_model](const float* p, std::int64_t n, float* sigma) {
    nerf_model.field().density(p, n, sigma);
  };
  const nerf::Box box = nerf_model.bounds();
  const Eigen::AlignedBox3d aabb(Eigen::Vector3d(box.min[0], box.min[1], box.min[2]),
                                 Eigen::Vector3d(box.max[0], box.max[1], box.max[2]));

  std::vector<double> grid_times;
  geometry::DensityGrid grid;
  for (int r = 0; r < repeat; ++r) {
    const auto start = Clock::now();
    grid = geometry::sampleDensityGrid(density, aabb, resolution);
    grid_times.push_back(since(start));
  }
  std::printf("density grid %dx%dx%d (cell %.2f mm): %.2f s (median of %d)\n", grid.dims.x(), grid.dims.y(),
              grid.dims.z(), 1e3 * grid.spacing.x(), median(grid_times), repeat);
  figures["resolution"] = resolution;
  figures["grid_seconds"] = median(grid_times);
  figures["cell_mm"] = 1e3 * grid.spacing.x();

  if (options.count("probe")) {
    // sigma and optical depth along lines through the crossbar (x = 0.1, z = 0.27) and stem.
    const geometry::DensityGrid tau = geometry::axisOpticalDepth(grid);
    const Eigen::Vector3d starts[3] = {{-0.19, 0.0, 0.27}, {0.1, -0.072, 0.27}, {0.0, 0.0, -0.042}};
    for (int axis = 0; axis < 3; ++axis) {
      std::printf("line along axis %d from (%g %g %g):\n", axis, starts[axis].x(), starts[axis].y(), starts[axis].z());
      for (int s = 0; s < 400; ++s) {
        Eigen::Vector3d p = starts[axis];
        p[axis] += s * 0.001;
        if (!aabb.contains(p)) break;
        float sigma = 0;
        const float q[3] = {float(p.x()), float(p.y()), float(p.z())};
        density(q, 1, &sigma);
        std::printf("  %+.3f sigma %9.2f grid %9.2f tau %8.3f\n", p[axis], sigma, geometry::sampleTrilinear(grid, p),
                    geometry::sampleTrilinear(tau, p));
      }
    }
  }
  struct Variant {
    std::string name;
    geometry::MeshExtractionConfig config;
  };
  std::vector<Variant> variants;
  auto list = [&](const std::string& key, const std::string& fallback) {
    std::vector<double> values;
    std::stringstream stream(get(options, key, fallback));
    for (std::string item; std::getline(stream, item, ',');) values.push_back(std::stod(item));
    return values;
  };
  for (double t : list("thresholds", "2.5,10,30")) {
    Variant v{"density " + std::to_string(t).substr(0, 5), {}};
    v.config.threshold = t;
    variants.push_back(v);
  }
  for (double alpha : list("opacities", "0.1,0.15,0.2,0.5")) {
    Variant v{"opacity " + std::to_string(alpha).substr(0, 4), {}};
    v.config.surface = geometry::SurfaceDefinition::kOpacity;
    v.config.opacity = alpha;
    variants.push_back(v);
  }
  {
    // What `demnerf extract` does by default.
    Variant v{"opacity 0.15 simplified", {}};
    v.config.surface = geometry::SurfaceDefinition::kOpacity;
    v.config.opacity = 0.15;
    v.config.simplification.max_faces = max_faces;
    variants.push_back(v);
    v.name = "opacity 0.15 simplified fast";
    v.config.simplification.fast = true;
    variants.push_back(v);
  }

  std::printf("%-24s %9s %9s %8s %9s %9s %9s %9s %8s\n", "surface", "faces", "volume", "vol err", "chamfer",
              "ch/diag", "ch_sum/d", "hausdorff", "extract");
  for (const auto& variant : variants) {
    std::vector<double> times;
    geometry::MeshExtractionResult result;
    try {
      for (int r = 0; r < repeat; ++r) {
        const auto start = Clock::now();
        result = geometry::extractMesh(grid, variant.config);
        times.push_back(since(start));
      }
    } catch (const std::exception& e) {
      std::printf("%-24s failed: %s\n", variant.name.c_str(), e.what());
      continue;
    }
    const geometry::MeshDistance d = geometry::meshDistance(result.mesh, truth);
    const double volume_error = result.volume / kExactVolume - 1.0;
    std::printf("%-24s %9zu %9.6f %+7.2f%% %7.3fmm %8.3f%% %8.3f%% %7.2fmm %7.2fs\n", variant.name.c_str(),
                result.faces, result.volume, 100 * volume_error, 1e3 * d.chamfer, 100 * d.chamfer / diagonal,
                100 * d.chamfer_sum / diagonal, 1e3 * d.hausdorff, median(times));
    figures["surfaces"][variant.name] = {{"faces", result.faces},
                                         {"volume", result.volume},
                                         {"volume_error", volume_error},
                                         {"chamfer", d.chamfer},
                                         {"chamfer_over_diagonal", d.chamfer / diagonal},
                                         {"chamfer_sum_over_diagonal", d.chamfer_sum / diagonal},
                                         {"hausdorff", d.hausdorff},
                                         {"closed", result.closed},
                                         {"components_removed", result.repair.components_removed},
                                         {"extract_seconds", median(times)}};
    if (options.count("probe")) {
      // Where the exact surface is far (> 5 mm) from the extracted one, by region.
      const auto samples = geometry::sampleSurfacePoints(truth, 20000, 9);
      const auto dist = geometry::distancesToMesh(result.mesh, samples);
      int far = 0;
      Eigen::AlignedBox3d where;
      std::map<std::string, int> by_face;
      for (std::size_t i = 0; i < samples.size(); ++i) {
        if (dist[i] < 0.005) continue;
        ++far;
        where.extend(samples[i]);
        const Eigen::Vector3d& q = samples[i];
        std::string face = std::abs(std::abs(q.y()) - 0.03) < 1e-6 ? "y-face" : std::abs(std::abs(q.x()) - 0.15) < 1e-6 ? "x-end"
                         : std::abs(q.z() - 0.3) < 1e-6 ? "top" : q.z() < 1e-6 ? "bottom" : std::abs(q.z() - 0.24) < 1e-6 ? "under-bar" : "stem-x";
        by_face[face]++;
      }
      std::printf("    far truth points: %d, box (%s) - (%s):", far, where.isEmpty() ? "" : "x", "");
      if (!where.isEmpty()) std::printf(" [%g %g %g]-[%g %g %g]", where.min().x(), where.min().y(), where.min().z(), where.max().x(), where.max().y(), where.max().z());
      for (const auto& [k, v] : by_face) std::printf(" %s:%d", k.c_str(), v);
      std::printf("\n");
      core::writeMesh(work + "/extracted_" + std::to_string(&variant - &variants[0]) + ".ply", result.mesh);
    }
    if (variant.name == "opacity 0.15 simplified") core::writeMesh(work + "/tbar_extracted.ply", result.mesh);
  }

  // Inside tests straight from density against the exact body.
  const geometry::InsideTest exact(truth);
  std::mt19937_64 rng(5);
  std::vector<Eigen::Vector3d> points(20000);
  for (auto& p : points) {
    for (int a = 0; a < 3; ++a) p[a] = std::uniform_real_distribution<double>(aabb.min()[a], aabb.max()[a])(rng);
  }
  struct InsideVariant {
    std::string name;
    std::unique_ptr<geometry::DensityInsideTest> test;
  };
  std::vector<InsideVariant> inside_tests;
  for (double t : {2.5, 30.0}) {
    geometry::DensityInsideConfig c;
    c.threshold = t;
    c.smoothing_radius = grid.spacing.x();
    inside_tests.push_back({"field sigma>" + std::to_string(t).substr(0, 4) + " smoothed",
                            std::make_unique<geometry::DensityInsideTest>(density, c)});
    c.smoothing_radius = 0;
    inside_tests.push_back({"grid sigma>" + std::to_string(t).substr(0, 4) + " trilinear",
                            std::make_unique<geometry::DensityInsideTest>(grid, c)});
  }
  {
    geometry::MeshExtractionConfig extraction;
    extraction.surface = geometry::SurfaceDefinition::kOpacity;
    extraction.opacity = 0.15;
    inside_tests.push_back({"grid opacity>0.15 trilinear", std::make_unique<geometry::DensityInsideTest>(
                                                               geometry::DensityInsideTest::matchingExtraction(grid, extraction))});
  }
  std::printf("\ninside test vs exact body, %zu random points in the box:\n", points.size());
  for (const auto& it : inside_tests) {
    const auto start = Clock::now();
    const auto inside = it.test->inside(points);
    const double seconds = since(start);
    int wrong = 0, wrong_far = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if ((inside[i] != 0) == exact.inside(points[i])) continue;
      ++wrong;
      wrong_far += exact.squaredDistance(points[i]) > 2e-3 * 2e-3;
    }
    std::printf("  %-30s wrong %5.2f%%, wrong > 2 mm from the surface %5.2f%%  (%.2f s)\n", it.name.c_str(),
                100.0 * wrong / points.size(), 100.0 * wrong_far / points.size(), seconds);
    figures["inside"][it.name] = {{"wrong", double(wrong) / points.size()},
                                  {"wrong_beyond_2mm", double(wrong_far) / points.size()}};
  }
  std::cout << figures.dump() << std::endl;
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "geometry_tbar_extraction: %s\n", e.what());
  return 1;
}
