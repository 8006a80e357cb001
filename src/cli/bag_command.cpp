// demnerf bag: a dataset folder written as the rosbag a camera rig would have recorded.

#include <chrono>

#include "command.hpp"
#include "conversions/dataset_bag.hpp"
#include "demnerf/core/error.hpp"

namespace demnerf::cli {
namespace {

Figures runBag(const Arguments& arguments) {
  arguments.rejectUnknown({"data", "out", "rate", "split", "downscale", "camera", "world-frame", "json"});
  const std::string out = arguments.text("out");
  const double rate = arguments.number("rate", 5.0);
  if (!(rate > 0)) throw UsageError("--rate must be positive (images per second)");
  const std::string split = arguments.text("split", "train");
  const std::string camera = arguments.text("camera", "camera");
  core::DatasetOptions options;
  options.downscale = arguments.number("downscale", 1.0);
  const auto start = std::chrono::steady_clock::now();
  const core::Dataset dataset = core::loadDataset(arguments.text("data"), options);
  const std::vector<core::Frame> frames = dataset.frames(split);
  if (frames.empty()) throw core::Error("the dataset has no " + split + " frames");

  dem_nerf::DatasetBagOptions bag_options;
  bag_options.rate = rate;
  bag_options.camera = camera;
  bag_options.naming.world_frame = arguments.text("world-frame", bag_options.naming.world_frame);
  dem_nerf::writeDatasetBag(out, frames, bag_options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return {{"frames", frames.size()}, {"bag", out}, {"seconds", seconds}};
}

}  // namespace

const Command kBagCommand = {"bag", "write a dataset as a rosbag (Image, CameraInfo, tf)",
                             "--data DIR --out X.bag [--rate 5] [--split train|test|all] [--downscale 1] "
                             "[--camera camera] [--world-frame world] [--json]",
                             runBag};

}  // namespace demnerf::cli
