#pragma once
// The axis-aligned box region the mechanics tests build their fixtures and loads from.

#include <Eigen/Core>

#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics::test {

inline core::Region box(const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  core::Region r;
  r.type = core::Region::Type::kBox;
  r.center = center;
  r.size = size;
  return r;
}

}  // namespace demnerf::mechanics::test
