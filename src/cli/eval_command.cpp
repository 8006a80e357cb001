// `demnerf eval`: PSNR and SSIM of a NeRF model on a dataset split (packages/nerf).

#include "command.hpp"
#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/model_io.hpp"

namespace demnerf::cli {
namespace {

Figures runEval(const Arguments& arguments) {
  arguments.rejectUnknown({"model", "data", "split", "downscale", "json", "quiet"});
  const std::string split = arguments.text("split", "test");
  if (split != "test" && split != "train") throw UsageError("--split must be 'test' or 'train', got '" + split + "'");
  core::DatasetOptions options;
  options.downscale = arguments.number("downscale", 1.0);
  if (options.downscale < 1.0) throw UsageError("--downscale must be >= 1");
  const nerf::NerfModel model = nerf::loadModel(arguments.text("model"));
  const core::Dataset dataset = core::loadDataset(arguments.text("data"), options);
  const nerf::Evaluation e = nerf::evaluate(model, dataset.split(split));
  return Figures{{"psnr", e.psnr}, {"ssim", e.ssim}, {"views", e.views}, {"seconds_per_view", e.seconds_per_view}};
}

}  // namespace

const Command kEvalCommand = {"eval", "PSNR and SSIM of a model on a dataset split",
                              "--model MODEL --data DIR [--split test] [--downscale F] [--json]", runEval};

}  // namespace demnerf::cli
