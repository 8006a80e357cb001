#pragma once
// A dataset written as the rosbag a camera rig would have recorded: /tf_static once, then
// Image + CameraInfo per frame at a fixed rate.

#include <string>
#include <vector>

#include "conversions/dataset_messages.hpp"

namespace dem_nerf {

struct DatasetBagOptions {
  double rate = 5.0;              ///< images per second of bag time
  std::string camera = "camera";  ///< topics /<camera>/image_raw and /<camera>/camera_info
  FrameNaming naming;
};

/// Writes atomically (temp file + rename). Throws demnerf::core::Error on an empty frame list.
void writeDatasetBag(const std::string& path, const std::vector<demnerf::core::Frame>& frames,
                     const DatasetBagOptions& options);

}  // namespace dem_nerf
