#pragma once
// A radiance field: density and colour at batches of world points, independent of how the
// points were chosen (ray marcher) or how they are combined (compositor), as f2-nerf splits them.

#include <cstdint>

namespace demnerf::nerf {

/// Axis-aligned box of the scene, in world coordinates (metres).
struct Box {
  float min[3] = {0, 0, 0};
  float max[3] = {1, 1, 1};
  float size(int axis) const { return max[axis] - min[axis]; }
};

/// What the marcher and the renderers ask a field. Const calls are thread-safe; each call
/// may use all torch threads. Points outside bounds() have zero density.
class Field {
 public:
  virtual ~Field() = default;
  virtual Box bounds() const = 0;
  /// sigma[n] (1/m) at points[n x 3].
  virtual void density(const float* points, std::int64_t n, float* sigma) const = 0;
  /// sigma[n] and rgb[n x 3] in [0, 1] for points[n x 3] seen along unit directions[n x 3].
  virtual void query(const float* points, const float* directions, std::int64_t n, float* sigma,
                     float* rgb) const = 0;
};

}  // namespace demnerf::nerf
