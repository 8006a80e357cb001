#include "conversions/dataset_bag.hpp"

#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include <filesystem>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

void writeDatasetBag(const std::string& path, const std::vector<demnerf::core::Frame>& frames,
                     const DatasetBagOptions& options) {
  if (frames.empty()) throw demnerf::core::Error("no frames to write to '" + path + "'");
  if (!(options.rate > 0)) throw demnerf::core::Error("bag rate must be positive");
  // A fixed, non-zero start time makes the bag reproducible (rosbag refuses time zero).
  const ros::Time start(1.0e9);
  const std::string temporary = path + ".tmp";
  rosbag::Bag bag(temporary, rosbag::bagmode::Write);
  tf2_msgs::TFMessage static_poses;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    static_poses.transforms.push_back(toMessages(frames[i], i, start, options.naming).pose);
  }
  bag.write("/tf_static", start, static_poses);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ros::Time stamp = start + ros::Duration((i + 1) / options.rate);
    const FrameMessages messages = toMessages(frames[i], i, stamp, options.naming);
    bag.write("/" + options.camera + "/image_raw", stamp, messages.image);
    bag.write("/" + options.camera + "/camera_info", stamp, messages.camera_info);
  }
  bag.close();
  std::filesystem::rename(temporary, path);
}

}  // namespace dem_nerf
