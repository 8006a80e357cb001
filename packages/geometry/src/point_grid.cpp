#include <cmath>
#include <limits>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

PointGrid::PointGrid(const Eigen::AlignedBox3d& box, double cell) : origin_(box.min()), cell_(cell) {
  const Eigen::Vector3d extent = box.max() - box.min();
  // Keep the table to a few million cells; coarser cells stay correct, only slower.
  constexpr double kMaxCells = 8e6;
  while ((extent / cell_).array().floor().matrix().prod() + 1 > kMaxCells) cell_ *= 1.5;
  dims_ = ((extent / cell_).array().floor() + 1).cast<int>().matrix();
  head_.assign(static_cast<std::size_t>(dims_.x()) * dims_.y() * dims_.z(), -1);
}

Eigen::Vector3i PointGrid::cellOf(const Eigen::Vector3d& point) const {
  Eigen::Vector3i cell;
  for (int a = 0; a < 3; ++a) {
    const double c = std::floor((point[a] - origin_[a]) / cell_);
    cell[a] = static_cast<int>(std::clamp(c, 0.0, static_cast<double>(dims_[a] - 1)));
  }
  return cell;
}

int PointGrid::insert(const Eigen::Vector3d& point) {
  const int id = static_cast<int>(points_.size());
  points_.push_back(point);
  const std::size_t c = cellIndex(cellOf(point));
  next_.push_back(head_[c]);
  head_[c] = id;
  return id;
}

bool PointGrid::anyWithin(const Eigen::Vector3d& point, double r) const {
  const Eigen::Vector3i c = cellOf(point);
  const double r2 = r * r;
  for (int z = std::max(0, c.z() - 1); z <= std::min(dims_.z() - 1, c.z() + 1); ++z) {
    for (int y = std::max(0, c.y() - 1); y <= std::min(dims_.y() - 1, c.y() + 1); ++y) {
      for (int x = std::max(0, c.x() - 1); x <= std::min(dims_.x() - 1, c.x() + 1); ++x) {
        for (int id = head_[cellIndex({x, y, z})]; id >= 0; id = next_[id]) {
          if ((points_[id] - point).squaredNorm() < r2) return true;
        }
      }
    }
  }
  return false;
}

int PointGrid::nearest(const Eigen::Vector3d& point) const {
  if (points_.empty()) return -1;
  const Eigen::Vector3i c = cellOf(point);
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  const int max_ring = dims_.maxCoeff();
  for (int ring = 0; ring <= max_ring; ++ring) {
    // Visit the cells whose Chebyshev distance from c is exactly `ring`.
    for (int z = c.z() - ring; z <= c.z() + ring; ++z) {
      if (z < 0 || z >= dims_.z()) continue;
      for (int y = c.y() - ring; y <= c.y() + ring; ++y) {
        if (y < 0 || y >= dims_.y()) continue;
        const bool y_or_z_on_shell = std::abs(z - c.z()) == ring || std::abs(y - c.y()) == ring;
        const int x_step = y_or_z_on_shell ? 1 : 2 * ring;
        for (int x = c.x() - ring; x <= c.x() + ring; x += std::max(1, x_step)) {
          if (x < 0 || x >= dims_.x()) continue;
          for (int id = head_[cellIndex({x, y, z})]; id >= 0; id = next_[id]) {
            const double d2 = (points_[id] - point).squaredNorm();
            if (d2 < best_d2) {
              best_d2 = d2;
              best = id;
            }
          }
        }
      }
    }
    // Points in rings beyond this one are at least ring * cell away.
    if (best >= 0 && best_d2 <= (ring * cell_) * (ring * cell_)) break;
  }
  return best;
}

int PointGrid::nearestFacing(const Eigen::Vector3d& point, const Eigen::Vector3d& direction,
                             const std::vector<Eigen::Vector3d>& directions) const {
  if (points_.empty()) return -1;
  const Eigen::Vector3i c = cellOf(point);
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  const int max_ring = dims_.maxCoeff();
  for (int ring = 0; ring <= max_ring; ++ring) {
    // Visit the cells whose Chebyshev distance from c is exactly `ring`.
    for (int z = c.z() - ring; z <= c.z() + ring; ++z) {
      if (z < 0 || z >= dims_.z()) continue;
      for (int y = c.y() - ring; y <= c.y() + ring; ++y) {
        if (y < 0 || y >= dims_.y()) continue;
        const bool y_or_z_on_shell = std::abs(z - c.z()) == ring || std::abs(y - c.y()) == ring;
        const int x_step = y_or_z_on_shell ? 1 : 2 * ring;
        for (int x = c.x() - ring; x <= c.x() + ring; x += std::max(1, x_step)) {
          if (x < 0 || x >= dims_.x()) continue;
          for (int id = head_[cellIndex({x, y, z})]; id >= 0; id = next_[id]) {
            if (directions[id].dot(direction) <= 0.0) continue;
            const double d2 = (points_[id] - point).squaredNorm();
            if (d2 < best_d2) {
              best_d2 = d2;
              best = id;
            }
          }
        }
      }
    }
    // Points in rings beyond this one are at least ring * cell away.
    if (best >= 0 && best_d2 <= (ring * cell_) * (ring * cell_)) break;
  }
  return best >= 0 ? best : nearest(point);
}

}  // namespace demnerf::geometry::detail
