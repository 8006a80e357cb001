#pragma once
// Picks keyframes from a stream of posed images: a view joins only when it sees the object
// from somewhere new, so a camera that stands still does not flood the training set.

#include <Eigen/Geometry>
#include <deque>

namespace demnerf::core {

struct KeyframeConfig {
  double min_translation = 0.02;      ///< m between a new keyframe and every kept one...
  double min_rotation_degrees = 5.0;  ///< ...or this much rotation
  std::size_t max_frames = 200;       ///< beyond this the oldest keyframe is dropped
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeConfig& config) : config_(config) {}

  /// True when the pose is far enough (in translation or rotation) from every kept keyframe;
  /// it is then kept. `evicted` is set when the oldest keyframe had to make room.
  bool offer(const Eigen::Isometry3d& world_from_camera, bool* evicted = nullptr);
  std::size_t size() const { return poses_.size(); }
  void clear() { poses_.clear(); }

 private:
  bool isNew(const Eigen::Isometry3d& pose) const;

  KeyframeConfig config_;
  std::deque<Eigen::Isometry3d> poses_;
};

}  // namespace demnerf::core
