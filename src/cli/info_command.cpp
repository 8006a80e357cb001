// demnerf info: what a dataset folder holds, before anything is trained on it.

#include "command.hpp"
#include "demnerf/core/dataset.hpp"

namespace demnerf::cli {
namespace {

Figures runInfo(const Arguments& arguments) {
  arguments.rejectUnknown({"data", "json"});
  core::DatasetOptions options;
  options.load_images = false;
  const core::Dataset dataset = core::loadDataset(arguments.text("data"), options);
  const core::PinholeCamera& camera = dataset.train.front().camera;
  const auto& box = dataset.bounds;
  return {{"layout", dataset.layout},
          {"train_views", dataset.train.size()},
          {"test_views", dataset.test.size()},
          {"missing_images", dataset.missing_images.size()},
          {"width", camera.width},
          {"height", camera.height},
          {"distortion", camera.hasDistortion()},
          {"aabb_min", {box.min().x(), box.min().y(), box.min().z()}},
          {"aabb_max", {box.max().x(), box.max().y(), box.max().z()}}};
}

}  // namespace

const Command kInfoCommand = {"info", "summary of a dataset folder (views, size, scene box)",
                              "--data DIR [--json]", runInfo};

}  // namespace demnerf::cli
