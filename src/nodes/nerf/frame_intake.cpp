#include "nodes/nerf/frame_intake.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/image_conversions.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {

FrameIntake::FrameIntake(const FrameIntakeConfig& config, const tf2_ros::Buffer& tf_buffer)
    : config_(config), tf_buffer_(tf_buffer), selector_(config.keyframes) {}

void FrameIntake::add(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.received;
  }
  try {
    if (image.width != info.width || image.height != info.height) {
      throw demnerf::core::Error("image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                                 " but its camera_info says " + std::to_string(info.width) + "x" +
                                 std::to_string(info.height));
    }
    Pending pending;
    pending.frame.camera = fromCameraInfo(info);
    pending.frame.rgba = toRgba(image, &pending.frame.has_alpha, config_.max_input_pixels);
    pending.frame.rgba = demnerf::core::fitToSize(pending.frame.rgba, config_.max_image_size, pending.frame.camera);
    if (!pending.frame.has_alpha && config_.colour_key) {
      demnerf::core::applyColourKey(pending.frame.rgba, *config_.colour_key);
      pending.frame.has_alpha = true;
    }
    pending.frame_id = image.header.frame_id;
    pending.frame.file_path = image.header.frame_id;
    pending.stamp = image.header.stamp;
    pending.received = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(mutex_);
    pending_.push_back(std::move(pending));
    if (pending_.size() > config_.max_pending) {
      pending_.pop_front();
      ++counts_.tf_too_slow;
    }
  } catch (const demnerf::core::Error&) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.rejected;
    throw;
  } catch (const std::exception& error) {  // OpenCV or allocation failures on a huge image
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++counts_.rejected;
    }
    throw demnerf::core::Error(std::string("image could not be prepared: ") + error.what());
  }
}

std::vector<demnerf::core::Frame> FrameIntake::poll(std::vector<std::string>* dropped) {
  std::vector<demnerf::core::Frame> keyframes;
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime now = ros::WallTime::now();
  for (auto it = pending_.begin(); it != pending_.end();) {
    std::string error;
    if (tf_buffer_.canTransform(config_.world_frame, it->frame_id, it->stamp, ros::Duration(0), &error)) {
      const auto transform = tf_buffer_.lookupTransform(config_.world_frame, it->frame_id, it->stamp);
      it->frame.world_from_camera = tf2::transformToEigen(transform);
      if (selector_.offer(it->frame.world_from_camera)) {
        keyframes.push_back(std::move(it->frame));
        ++counts_.keyframes;
      } else {
        ++counts_.not_new;
      }
      it = pending_.erase(it);
    } else if ((now - it->received).toSec() > config_.tf_timeout) {
      const bool known = tf_buffer_._frameExists(it->frame_id);
      ++(known ? counts_.tf_too_slow : counts_.tf_missing);
      if (dropped != nullptr) {
        dropped->push_back("image dropped: " +
                           (known ? "tf from '" + config_.world_frame + "' to '" + it->frame_id +
                                        "' did not reach the image stamp within " + std::to_string(config_.tf_timeout) + " s"
                                  : "no tf from '" + config_.world_frame + "' to the image frame '" + it->frame_id +
                                        "' (is the camera's frame published?)"));
      }
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
  return keyframes;
}

FrameIntakeCounts FrameIntake::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counts_;
}

void FrameIntake::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.clear();
  selector_.clear();
  counts_ = {};
}

}  // namespace dem_nerf
