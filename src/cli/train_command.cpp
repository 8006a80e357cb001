// `demnerf train`: an instant-NGP style NeRF trained on a posed-image dataset (packages/nerf).

#include <iostream>

#include "command.hpp"
#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "runtime/configure_runtime.hpp"

namespace demnerf::cli {
namespace {

Figures runTrain(const Arguments& arguments) {
  arguments.rejectUnknown({"data", "out", "seconds", "iterations", "config", "downscale", "threads", "seed", "json",
                           "quiet"});
  const std::string data = arguments.text("data");
  const std::string out = arguments.text("out");
  nerf::NerfConfig config = arguments.has("config") ? nerf::loadNerfConfig(arguments.text("config")) : nerf::NerfConfig{};
  if (arguments.has("threads")) config.train.threads = arguments.integer("threads", 0);
  if (arguments.has("seed")) config.train.seed = static_cast<std::uint64_t>(arguments.integer("seed", 1));
  config.validate();
  if (config.train.threads > 0) dem_nerf::configureRuntime({config.train.threads, false, true});  // a config file's count
  nerf::StopCriteria stop;
  stop.seconds = arguments.number("seconds", 0.0);
  stop.iterations = arguments.integer("iterations", 0);
  if (stop.seconds < 0 || stop.iterations < 0) throw UsageError("--seconds and --iterations must be >= 0");
  if (stop.seconds == 0 && stop.iterations == 0) stop.seconds = 60.0;
  core::DatasetOptions options;
  options.downscale = arguments.number("downscale", 1.0);
  if (options.downscale < 1.0) throw UsageError("--downscale must be >= 1, got " + std::to_string(options.downscale));

  const core::Dataset dataset = core::loadDataset(data, options);
  if (!dataset.missing_images.empty() && !arguments.flag("quiet")) {
    std::cerr << "demnerf train: " << dataset.missing_images.size() << " frames listed in '" << data
              << "' have no image and were skipped\n";
  }
  nerf::Trainer trainer(config, nerf::datasetBox(dataset), dataset.aabb_scale);
  trainer.addFrames(dataset.train);
  const nerf::TrainProgress progress = trainer.train(stop, {}, !arguments.flag("quiet"));
  nerf::saveModel(trainer.model(), out);
  const nerf::StepTimes& t = trainer.times();
  return Figures{{"seconds", progress.seconds},
                 {"iterations", progress.iteration},
                 {"psnr_train", progress.psnr},
                 {"loss", progress.loss},
                 {"frames", dataset.train.size()},
                 {"samples_per_ray", progress.samples_per_ray},
                 {"occupied_fraction", progress.occupied_fraction},
                 {"seconds_march_forward", t.march_forward},
                 {"seconds_backward_mlp", t.backward_mlp},
                 {"seconds_backward_table", t.backward_table},
                 {"seconds_optimizer", t.optimizer},
                 {"seconds_occupancy", t.occupancy},
                 {"model", out}};
}

}  // namespace

const Command kTrainCommand = {
    "train", "train a NeRF on a posed-image dataset",
    "--data DIR --out MODEL [--seconds S | --iterations N] [--config nerf.yaml] [--downscale F] [--threads N] "
    "[--seed N] [--quiet] [--json]",
    runTrain};

}  // namespace demnerf::cli
