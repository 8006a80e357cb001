// Render cost against marching settings on a trained model: held-out PSNR, seconds and field
// samples per pixel for each (render_cone_angle, render_min_transmittance) pair, the weights
// and occupancy grid kept. Shows what a render-time setting buys before it goes into a config.
//   nerf_render_sweep --model M.nerf --data DIR [--downscale 4] [--cones 0,0.0039,0.0156]
//                     [--transmittance 1e-4,1e-3,1e-2]

#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/model_io.hpp"

using namespace demnerf;

namespace {

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) out.push_back(std::stod(item));
  return out;
}

/// The same weights and grid under another march config.
nerf::NerfModel withMarch(const nerf::NerfModel& model, double cone, double transmittance) {
  nerf::NerfConfig config = model.config();
  config.march.render_cone_angle = cone;
  config.march.render_min_transmittance = transmittance;
  nerf::NerfModel copy(config, model.bounds(), model.aabbScale());
  copy.ngp().table() = model.ngp().table();
  copy.ngp().densityWeights() = model.ngp().densityWeights();
  copy.ngp().colorWeights() = model.ngp().colorWeights();
  copy.ngp().refreshTransposed();
  copy.grid().thickness() = model.grid().thickness();
  copy.grid().bits() = model.grid().bits();
  return copy;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  auto get = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  if (!args.count("model") || !args.count("data")) {
    std::fprintf(stderr, "usage: nerf_render_sweep --model M.nerf --data DIR [--downscale 4] [--cones a,b] "
                         "[--transmittance a,b]\n");
    return 2;
  }
  try {
    core::DatasetOptions options;
    options.downscale = std::stod(get("downscale", "1"));
    const core::Dataset dataset = core::loadDataset(args["data"], options);
    const nerf::NerfModel model = nerf::loadModel(args["model"]);
    std::printf("cone_angle,min_transmittance,test_psnr,seconds_per_view,samples_per_pixel\n");
    for (double cone : numbers(get("cones", std::to_string(model.renderMarch().cone_angle)))) {
      for (double t : numbers(get("transmittance", std::to_string(model.renderMarch().min_transmittance)))) {
        const nerf::Evaluation e = nerf::evaluate(withMarch(model, cone, t), dataset.test, false);
        std::printf("%g,%g,%.3f,%.3f,%.1f\n", cone, t, e.psnr, e.seconds_per_view, e.samples_per_pixel);
        std::fflush(stdout);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nerf_render_sweep: %s\n", e.what());
    return 1;
  }
  return 0;
}
