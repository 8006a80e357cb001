#pragma once
// A PointCloud2's layout checked completely before any byte is read: sizes in 64-bit arithmetic
// (width x height x point_step against row_step and data), every declared field inside
// point_step, known datatypes, and the fields we read declared as FLOAT32 or FLOAT64. Values are
// then read through the checked offsets only, so a lying header cannot make us read out of
// bounds (issue 14: point_step 0, an offset of 4e9, UINT8 declared on float data).

#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace dem_nerf {

class CloudLayout {
 public:
  /// Checks the header against the data; throws demnerf::core::Error naming the first problem
  /// (`what` starts the message: "particle cloud"). More than max_points points is refused.
  CloudLayout(const sensor_msgs::PointCloud2& message, const std::string& what,
              std::uint64_t max_points = std::numeric_limits<std::uint64_t>::max());

  std::size_t points() const { return points_; }
  bool has(const std::string& name) const;
  /// The named field's value at every point, as double. Throws demnerf::core::Error when the
  /// field is missing or not FLOAT32/FLOAT64.
  std::vector<double> read(const std::string& name) const;

 private:
  const sensor_msgs::PointCloud2& message_;
  std::string what_;
  std::size_t points_ = 0;
};

/// Bytes of one value of a sensor_msgs/PointField datatype; 0 for an unknown datatype.
std::uint32_t pointFieldSize(std::uint8_t datatype);

}  // namespace dem_nerf
