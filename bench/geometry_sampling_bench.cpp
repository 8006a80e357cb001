// Seconds per sampler (random, poisson, grid) on a mesh at a spacing of a fraction of its
// bounding-box diagonal; median of N runs, single-threaded. Prints one line per method and a
// JSON summary as the last line.
//   geometry_sampling_bench [--mesh spot.obj] [--fraction 0.02] [--runs 3]

#include <algorithm>
#include <chrono>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/particle_sampler.hpp"

using namespace demnerf;

int main(int argc, char** argv) {
  std::string mesh_path = std::string(DEMNERF_SHARED_DIR) + "/data/meshes/spot.obj";
  double fraction = 0.02;
  int runs = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--mesh") mesh_path = argv[i + 1];
    else if (key == "--fraction") fraction = std::stod(argv[i + 1]);
    else if (key == "--runs") runs = std::max(1, std::stoi(argv[i + 1]));
    else {
      std::cerr << "unknown option " << key << "\n";
      return 2;
    }
  }
  try {
    const auto read_start = std::chrono::steady_clock::now();
    const core::TriangleMesh mesh = core::readMesh(mesh_path);
    const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
    const geometry::MeshSummary summary = geometry::analyzeMesh(mesh);
    const double spacing = fraction * summary.diagonal();
    std::cout << mesh_path << ": " << summary.vertices << " vertices, " << summary.faces << " faces, volume "
              << summary.volume() << ", area " << summary.area << ", diagonal " << summary.diagonal()
              << ", spacing " << spacing << " (read " << read_seconds << " s)\n";
    nlohmann::json json = {{"mesh", mesh_path}, {"spacing", spacing}, {"fraction", fraction}, {"runs", runs}};
    for (auto method : {geometry::SamplingMethod::kRandom, geometry::SamplingMethod::kPoisson,
                        geometry::SamplingMethod::kGrid}) {
      geometry::SamplerConfig config;
      config.method = method;
      config.spacing = spacing;
      std::vector<double> seconds;
      geometry::SamplingReport report;
      for (int run = 0; run < runs; ++run) {
        config.seed = 1 + run;
        const auto start = std::chrono::steady_clock::now();
        geometry::sampleParticles(mesh, config, &report);
        seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      }
      std::sort(seconds.begin(), seconds.end());
      const double median = seconds[seconds.size() / 2];
      const char* name = geometry::samplingMethodName(method);
      std::cout << name << ": median " << median << " s (min " << seconds.front() << ", max " << seconds.back()
                << "), " << report.interior << " interior + " << report.surface << " surface particles, volume sum "
                << report.volume_sum << " / " << report.mesh_volume << ", area sum " << report.area_sum << " / "
                << report.mesh_area << "\n";
      json[name] = {{"median_seconds", median}, {"interior", report.interior}, {"surface", report.surface}};
    }
    std::cout << json.dump() << std::endl;
  } catch (const core::Error& error) {
    std::cerr << "geometry_sampling_bench: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
