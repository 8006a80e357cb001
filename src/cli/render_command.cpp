// `demnerf render`: images of a NeRF model from a dataset split's cameras (packages/nerf).

#include <algorithm>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>

#include "command.hpp"
#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/metrics.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/render/deformed_renderer.hpp"

namespace demnerf::cli {
namespace {

Figures runRender(const Arguments& arguments) {
  arguments.rejectUnknown({"model", "data", "split", "out", "result", "truth", "downscale", "json", "quiet"});
  const std::string split = arguments.text("split", "test");
  if (split != "test" && split != "train") throw UsageError("--split must be 'test' or 'train', got '" + split + "'");
  core::DatasetOptions options;
  options.downscale = arguments.number("downscale", 1.0);
  options.load_images = false;  // only the cameras are needed
  if (options.downscale < 1.0) throw UsageError("--downscale must be >= 1");
  const std::string out = arguments.text("out");
  const nerf::NerfModel model = nerf::loadModel(arguments.text("model"));
  // With --result the body is bent by the simulated displacement: each ray sample is mapped
  // back to its rest position through a tetrahedral embedding of the result's particles.
  std::unique_ptr<render::DeformedScene> deformed;
  if (arguments.has("result")) {
    deformed = std::make_unique<render::DeformedScene>(model, core::readResult(arguments.text("result")));
  }
  const core::Dataset dataset = core::loadDataset(arguments.text("data"), options);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw core::Error("cannot create output directory '" + out + "': " + ec.message());
  const auto& frames = dataset.split(split);
  // --truth: a dataset with the same cameras and the images the renders should match (for a
  // deformed render: `demnerf synth --result R.ply`), compared view by view.
  std::vector<core::Frame> truth;
  if (arguments.has("truth")) {
    core::DatasetOptions truth_options;
    truth_options.downscale = options.downscale;
    truth = core::loadDataset(arguments.text("truth"), truth_options).split(split);
    if (truth.size() != frames.size())
      throw core::Error("--truth has " + std::to_string(truth.size()) + " " + split + " views, --data has " +
                        std::to_string(frames.size()) + ": they must come from the same cameras");
  }
  const auto& bg = model.config().background;
  const cv::Vec3f background(static_cast<float>(bg[0]), static_cast<float>(bg[1]), static_cast<float>(bg[2]));
  std::vector<double> view_psnr, view_ssim;
  double seconds = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const nerf::RenderedImage image =
        deformed ? render::renderDeformed(*deformed, frames[i].camera, frames[i].world_from_camera)
                 : nerf::renderImage(model, frames[i].camera, frames[i].world_from_camera);
    seconds += image.seconds;
    if (!truth.empty()) {
      const cv::Mat expected = core::compositeOver(truth[i].rgba, background);
      view_psnr.push_back(core::psnr(image.color, expected));
      view_ssim.push_back(core::ssim(image.color, expected));
    }
    char name[64];
    std::snprintf(name, sizeof(name), "r_%03zu.png", i);
    core::writeImagePng((std::filesystem::path(out) / name).string(), nerf::toRgba(image));
  }
  Figures figures{{"views", frames.size()},
                  {"seconds_per_view", frames.empty() ? 0.0 : seconds / static_cast<double>(frames.size())},
                  {"out", out}};
  if (!view_psnr.empty()) {
    std::vector<double> sorted = view_psnr;
    std::sort(sorted.begin(), sorted.end());
    figures["psnr_median"] = sorted[sorted.size() / 2];
    figures["psnr_min"] = sorted.front();
    double ssim_sum = 0;
    for (double v : view_ssim) ssim_sum += v;
    figures["ssim_mean"] = ssim_sum / static_cast<double>(view_ssim.size());
  }
  return figures;
}

}  // namespace

const Command kRenderCommand = {
    "render", "render a model (optionally deformed) from a split's cameras",
    "--model MODEL --data DIR --split test --out DIR [--result R.ply] [--truth DIR] [--downscale F] [--json]", runRender};

}  // namespace demnerf::cli
