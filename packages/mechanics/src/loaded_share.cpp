#include "demnerf/mechanics/loaded_share.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "demnerf/mechanics/dirichlet_lift.hpp"

namespace demnerf::mechanics {

double loadedShare(const core::Region& region, const Eigen::Vector3d& position, const Eigen::Vector3d& normal,
                   double area) {
  if (!(area > 0.0)) return 0.0;
  if (!(normal.squaredNorm() > 0.25)) return region.contains(position) ? 1.0 : 0.0;
  const double side = std::sqrt(area);
  if (regionDistance(region, position) > side) return 0.0;  // farther than the square reaches
  // Regions often end exactly on a face (the T-bar's load patches at its arms' ends, x = 0.15):
  // a particle written to a PLY in float32 then lies 6e-9 m outside, and the face's strip would
  // drop out of the load (1.6 % of the T-bar's couple on `demnerf simulate`, none in-process). So
  // the sub-points count within a rounding tolerance of the region.
  const double tolerance = 1e-6 * (position.cwiseAbs().maxCoeff() + side);
  const auto within = [&](const Eigen::Vector3d& q) {
    return region.contains(q) || regionDistance(region, q) <= tolerance;
  };
  // Tangents: the coordinate axis least aligned with the normal, projected into the plane, so
  // that faces parallel to a box region's sides are clipped along its sides.
  const Eigen::Vector3d n = normal.normalized();
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n(k)) < std::abs(n(axis))) axis = k;
  const Eigen::Vector3d t1 = Eigen::Vector3d::Unit(axis).cross(n).normalized();
  const Eigen::Vector3d t2 = n.cross(t1);
  bool whole = true;
  for (int c = 0; c < 4 && whole; ++c)
    whole = within(position + 0.5 * side * ((c & 1 ? 1.0 : -1.0) * t1 + (c & 2 ? 1.0 : -1.0) * t2));
  if (whole) return 1.0;
  constexpr int kSub = 8;
  int count = 0;
  for (int b = 0; b < kSub; ++b)
    for (int a = 0; a < kSub; ++a)
      count += within(position + side * (((a + 0.5) / kSub - 0.5) * t1 + ((b + 0.5) / kSub - 0.5) * t2));
  return static_cast<double>(count) / (kSub * kSub);
}

}  // namespace demnerf::mechanics
