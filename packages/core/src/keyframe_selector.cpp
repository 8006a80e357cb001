#include "demnerf/core/keyframe_selector.hpp"

#include <cmath>

namespace demnerf::core {

bool KeyframeSelector::isNew(const Eigen::Isometry3d& pose) const {
  const double min_angle = config_.min_rotation_degrees * M_PI / 180.0;
  for (const Eigen::Isometry3d& kept : poses_) {
    const double translation = (kept.translation() - pose.translation()).norm();
    const double angle = Eigen::AngleAxisd(kept.linear().transpose() * pose.linear()).angle();
    if (translation < config_.min_translation && angle < min_angle) return false;
  }
  return true;
}

bool KeyframeSelector::offer(const Eigen::Isometry3d& world_from_camera, bool* evicted) {
  if (evicted != nullptr) *evicted = false;
  if (!world_from_camera.matrix().allFinite() || !isNew(world_from_camera)) return false;
  poses_.push_back(world_from_camera);
  if (poses_.size() > config_.max_frames) {
    poses_.pop_front();
    if (evicted != nullptr) *evicted = true;
  }
  return true;
}

}  // namespace demnerf::core
