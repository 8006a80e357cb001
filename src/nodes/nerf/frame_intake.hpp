#pragma once
// Turns the rig's (image, camera_info) pairs into posed keyframes. Poses come from tf at the
// image stamp; an image whose pose is not there yet waits in a short queue (tf often lags the
// camera), and is dropped after ~tf_timeout, counted as "tf missing" when its frame is unknown
// to tf and as "too slow" when the frame exists but tf never caught up with the stamp.

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>

#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/image_preparation.hpp"
#include "demnerf/core/keyframe_selector.hpp"

namespace dem_nerf {

struct FrameIntakeConfig {
  std::string world_frame = "world";
  double tf_timeout = 0.5;
  int max_image_size = 400;
  std::optional<demnerf::core::ColourKey> colour_key;  ///< for images without alpha
  demnerf::core::KeyframeConfig keyframes;
  std::size_t max_pending = 30;  ///< images waiting for tf; the oldest is dropped beyond
  std::uint64_t max_input_pixels = 4096ull * 4096ull;  ///< larger images are refused before decoding
};

struct FrameIntakeCounts {
  std::size_t received = 0;
  std::size_t keyframes = 0;
  std::size_t not_new = 0;      ///< too close to an existing keyframe
  std::size_t rejected = 0;     ///< bad encoding, size or intrinsics
  std::size_t tf_missing = 0;   ///< the image's frame never appeared in tf
  std::size_t tf_too_slow = 0;  ///< the frame exists, but tf never reached the image stamp
};

class FrameIntake {
 public:
  FrameIntake(const FrameIntakeConfig& config, const tf2_ros::Buffer& tf_buffer);

  /// Validates and queues one image; throws demnerf::core::Error saying why it is unusable.
  void add(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info);
  /// Resolves queued images whose pose is now in tf; returns the new keyframes (posed, RGBA).
  /// Images dropped for lack of tf are described in `dropped` (one line each).
  std::vector<demnerf::core::Frame> poll(std::vector<std::string>* dropped);
  FrameIntakeCounts counts() const;
  void reset();

 private:
  struct Pending {
    demnerf::core::Frame frame;
    std::string frame_id;
    ros::Time stamp;
    ros::WallTime received;
  };

  FrameIntakeConfig config_;
  const tf2_ros::Buffer& tf_buffer_;
  mutable std::mutex mutex_;
  std::deque<Pending> pending_;
  demnerf::core::KeyframeSelector selector_;
  FrameIntakeCounts counts_;
};

}  // namespace dem_nerf
