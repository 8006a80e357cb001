#include "conversions/cloud_layout.hpp"

#include <sensor_msgs/PointField.h>

#include <algorithm>
#include <cstring>

#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;
using sensor_msgs::PointField;

}  // namespace

std::uint32_t pointFieldSize(std::uint8_t datatype) {
  switch (datatype) {
    case PointField::INT8:
    case PointField::UINT8: return 1;
    case PointField::INT16:
    case PointField::UINT16: return 2;
    case PointField::INT32:
    case PointField::UINT32:
    case PointField::FLOAT32: return 4;
    case PointField::FLOAT64: return 8;
    default: return 0;
  }
}

CloudLayout::CloudLayout(const sensor_msgs::PointCloud2& message, const std::string& what, std::uint64_t max_points)
    : message_(message), what_(what) {
  const std::uint64_t width = message.width, height = message.height, step = message.point_step;
  const std::uint64_t rows = width * height;  // both < 2^32: no overflow in 64 bits
  if (rows == 0) throw Error(what + " is empty (width " + std::to_string(width) + ", height " + std::to_string(height) + ")");
  if (rows > max_points)
    throw Error(what + " has " + std::to_string(rows) + " points, more than the limit of " + std::to_string(max_points) +
                " (raise ~max_particles if the memory allows, or sample coarser)");
  if (step == 0) throw Error(what + " has point_step 0");
  if (message.is_bigendian) throw Error(what + " is big-endian; only little-endian clouds are read");
  for (const PointField& field : message.fields) {
    const std::uint64_t size = pointFieldSize(field.datatype);
    if (size == 0)
      throw Error(what + ": field '" + field.name + "' has unknown datatype " + std::to_string(field.datatype));
    const std::uint64_t end = static_cast<std::uint64_t>(field.offset) + size * std::max<std::uint64_t>(field.count, 1);
    if (end > step)
      throw Error(what + ": field '" + field.name + "' (offset " + std::to_string(field.offset) + ", " +
                  std::to_string(end - field.offset) + " bytes) does not fit in point_step " + std::to_string(step));
  }
  if (static_cast<std::uint64_t>(message.row_step) != width * step)
    throw Error(what + ": row_step " + std::to_string(message.row_step) + " is not width x point_step = " +
                std::to_string(width * step));
  if (static_cast<std::uint64_t>(message.data.size()) != rows * step)
    throw Error(what + ": data holds " + std::to_string(message.data.size()) + " bytes, but width x height x point_step = " +
                std::to_string(rows * step));
  points_ = static_cast<std::size_t>(rows);
}

bool CloudLayout::has(const std::string& name) const {
  return std::any_of(message_.fields.begin(), message_.fields.end(),
                     [&](const PointField& field) { return field.name == name; });
}

std::vector<double> CloudLayout::read(const std::string& name) const {
  const auto field = std::find_if(message_.fields.begin(), message_.fields.end(),
                                  [&](const PointField& f) { return f.name == name; });
  if (field == message_.fields.end()) throw Error(what_ + " has no '" + name + "' field");
  if (field->datatype != PointField::FLOAT32 && field->datatype != PointField::FLOAT64)
    throw Error(what_ + ": field '" + name + "' has datatype " + std::to_string(field->datatype) +
                ", but FLOAT32 (7) or FLOAT64 (8) is needed");
  const bool wide = field->datatype == PointField::FLOAT64;
  const std::size_t step = message_.point_step;
  std::vector<double> values(points_);
  const std::uint8_t* data = message_.data.data();
  for (std::size_t i = 0; i < points_; ++i) {
    const std::uint8_t* at = data + i * step + field->offset;  // inside data: checked in the constructor
    if (wide) {
      std::memcpy(&values[i], at, sizeof(double));
    } else {
      float value;
      std::memcpy(&value, at, sizeof(float));
      values[i] = value;
    }
  }
  return values;
}

}  // namespace dem_nerf
