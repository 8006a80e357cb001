// Render cost against marching settings on a trained model: held-out PSNR, seconds and field
// samples per pixel for each (render_cone_angle, render_min_transmittance) pair, the weights
// and occupancy grid kept. Shows what a render-time setting buys before it goes into a config.
//   nerf_render_sweep --model M.nerf --data DIR [--downscale 4] [--cones 0,0.0039,0.0156]
//                     [--transmittance 1e-4,1e-3,1e-2] [--census 1]
// --census 1 first prints where the training march's samples go (by compositing weight).

#include <ATen/Parallel.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/compositing.hpp"
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

/// Where the training march's samples go on the held-out views (every 8th pixel): per ray,
/// samples by their compositing weight and by the transmittance in front of them. Says which
/// samples a cheaper march could drop.
void sampleCensus(const nerf::NerfModel& model, const std::vector<core::Frame>& frames) {
  const nerf::MarchParams& params = model.march();
  std::vector<float> pos(3 * params.max_samples), t(params.max_samples), dt(params.max_samples);
  std::vector<float> dirs(3 * params.max_samples), sigma(params.max_samples), rgb(3 * params.max_samples);
  double rays = 0, total = 0, by_weight[4] = {0, 0, 0, 0}, behind = 0;
  for (const core::Frame& frame : frames) {
    const Eigen::Matrix3d r = frame.world_from_camera.linear();
    const Eigen::Vector3f o = frame.world_from_camera.translation().cast<float>();
    for (int y = 4; y < frame.camera.height; y += 8) {
      for (int x = 4; x < frame.camera.width; x += 8) {
        const Eigen::Vector3f d = (r * frame.camera.unproject(Eigen::Vector2d(x + 0.5, y + 0.5))).normalized().cast<float>();
        nerf::RayCursor cursor;
        nerf::startRay(params, model.bounds(), o.data(), d.data(), 0.5f, cursor);
        const int n = nerf::marchRay(params, model.grid(), cursor, params.max_samples, pos.data(), t.data(), dt.data());
        for (int i = 0; i < n; ++i) std::copy(d.data(), d.data() + 3, dirs.data() + 3 * i);
        if (n > 0) model.field().query(pos.data(), dirs.data(), n, sigma.data(), rgb.data());
        nerf::RayAccum acc;
        ++rays;
        for (int i = 0; i < n && acc.transmittance >= params.min_transmittance; ++i) {
          behind += acc.transmittance < 0.1f;
          const float w = acc.add(sigma[i], dt[i], rgb.data() + 3 * i, t[i]);
          by_weight[w >= 1e-2f ? 0 : w >= 1e-3f ? 1 : w >= 1e-4f ? 2 : 3] += 1;
          ++total;
        }
      }
    }
  }
  std::printf("census: per ray %.1f samples: weight >= 1e-2 %.1f, 1e-3..1e-2 %.1f, 1e-4..1e-3 %.1f, < 1e-4 %.1f; "
              "behind transmittance 0.1 %.1f\n", total / rays, by_weight[0] / rays, by_weight[1] / rays,
              by_weight[2] / rays, by_weight[3] / rays, behind / rays);
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
    // Every core: Debian's libtorch starts with one thread, and its count is OpenMP's, which the
    // renderer's kernels use (the product's entry points do the same, configureRuntime).
    at::set_num_threads(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    core::DatasetOptions options;
    options.downscale = std::stod(get("downscale", "1"));
    const core::Dataset dataset = core::loadDataset(args["data"], options);
    const nerf::NerfModel model = nerf::loadModel(args["model"]);
    if (get("census", "0") == "1") sampleCensus(model, dataset.test);
    // cpu_seconds_per_view: this process's CPU time per view; on an idle machine with T cores a
    // view takes about cpu / T wall seconds, which a loaded machine's wall seconds do not show.
    std::printf("cone_angle,min_transmittance,test_psnr,seconds_per_view,samples_per_pixel,cpu_seconds_per_view,"
                "cpu_us_per_sample\n");
    for (double cone : numbers(get("cones", std::to_string(model.renderMarch().cone_angle)))) {
      for (double t : numbers(get("transmittance", std::to_string(model.renderMarch().min_transmittance)))) {
        const nerf::NerfModel variant = withMarch(model, cone, t);
        const double cpu0 = static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
        const nerf::Evaluation e = nerf::evaluate(variant, dataset.test, false);
        const double cpu = (static_cast<double>(std::clock()) / CLOCKS_PER_SEC - cpu0) / e.views;
        const double pixels = static_cast<double>(dataset.test[0].camera.width) * dataset.test[0].camera.height;
        std::printf("%g,%g,%.3f,%.3f,%.1f,%.3f,%.3f\n", cone, t, e.psnr, e.seconds_per_view, e.samples_per_pixel, cpu,
                    1e6 * cpu / (e.samples_per_pixel * pixels));
        std::fflush(stdout);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nerf_render_sweep: %s\n", e.what());
    return 1;
  }
  return 0;
}
