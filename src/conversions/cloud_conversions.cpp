#include "conversions/cloud_conversions.hpp"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "conversions/cloud_layout.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

float packRgb(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  const std::uint32_t packed = (static_cast<std::uint32_t>(r) << 16) | (static_cast<std::uint32_t>(g) << 8) | b;
  float value;
  std::memcpy(&value, &packed, sizeof(value));
  return value;
}

// A blue-to-red ramp, so that rviz's RGB8 colour transformer shows displacement magnitude.
std::array<std::uint8_t, 3> ramp(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return {static_cast<std::uint8_t>(255 * t), static_cast<std::uint8_t>(255 * (1 - std::abs(2 * t - 1))),
          static_cast<std::uint8_t>(255 * (1 - t))};
}

void setFloatFields(sensor_msgs::PointCloud2& message, const std::vector<std::string>& names, std::size_t rows) {
  sensor_msgs::PointCloud2Modifier modifier(message);
  message.fields.clear();
  int offset = 0;
  for (const auto& name : names) {
    sensor_msgs::PointField field;
    field.name = name;
    field.offset = offset;
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    message.fields.push_back(field);
    offset += 4;
  }
  message.point_step = offset;
  message.height = 1;
  message.is_bigendian = false;
  message.is_dense = true;
  modifier.resize(rows);
}

void writeRow(sensor_msgs::PointCloud2& message, std::size_t row, const std::vector<float>& values) {
  std::memcpy(&message.data[row * message.point_step], values.data(), values.size() * sizeof(float));
}

}  // namespace

sensor_msgs::PointCloud2 toPointCloud2(const demnerf::core::ParticleCloud& cloud, const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 message;
  message.header = header;
  setFloatFields(message, {"x", "y", "z", "volume", "nx", "ny", "nz", "area", "rgb"}, cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.positions[i];
    const auto& n = cloud.normals[i];
    const auto& c = cloud.colors[i];
    writeRow(message, i, {float(p.x()), float(p.y()), float(p.z()), float(cloud.volumes[i]), float(n.x()),
                          float(n.y()), float(n.z()), float(cloud.areas[i]), packRgb(c[0], c[1], c[2])});
  }
  return message;
}

demnerf::core::ParticleCloud particlesFromPointCloud2(const sensor_msgs::PointCloud2& message,
                                                      std::uint64_t max_points) {
  const CloudLayout layout(message, "particle cloud", max_points);
  const std::vector<double> x = layout.read("x"), y = layout.read("y"), z = layout.read("z");
  demnerf::core::ParticleCloud cloud;
  cloud.resize(layout.points());
  for (std::size_t i = 0; i < cloud.size(); ++i) cloud.positions[i] = {x[i], y[i], z[i]};
  const bool full = layout.has("volume") && layout.has("nx") && layout.has("area");
  if (full) {
    const std::vector<double> volume = layout.read("volume"), nx = layout.read("nx"), ny = layout.read("ny"),
                              nz = layout.read("nz"), area = layout.read("area");
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      cloud.volumes[i] = volume[i];
      cloud.normals[i] = {nx[i], ny[i], nz[i]};
      cloud.areas[i] = area[i];
    }
  } else {
    std::fill(cloud.volumes.begin(), cloud.volumes.end(), 1.0);
  }
  cloud.validate();
  return cloud;
}

sensor_msgs::PointCloud2 toPointCloud2(const demnerf::core::ResultField& result, const std_msgs::Header& header,
                                       bool displaced_positions) {
  sensor_msgs::PointCloud2 message;
  message.header = header;
  setFloatFields(message, {"x", "y", "z", "ux", "uy", "uz", "von_mises", "rgb"}, result.size());
  double largest = 0.0;
  for (const auto& u : result.displacements) largest = std::max(largest, u.norm());
  for (std::size_t i = 0; i < result.size(); ++i) {
    const auto& u = result.displacements[i];
    const Eigen::Vector3d p = displaced_positions ? Eigen::Vector3d(result.positions[i] + u) : result.positions[i];
    const auto c = ramp(largest > 0 ? u.norm() / largest : 0.0);
    writeRow(message, i, {float(p.x()), float(p.y()), float(p.z()), float(u.x()), float(u.y()), float(u.z()),
                          float(result.von_mises[i]), packRgb(c[0], c[1], c[2])});
  }
  return message;
}

demnerf::core::ResultField resultFromPointCloud2(const sensor_msgs::PointCloud2& message, bool displaced_positions) {
  const CloudLayout layout(message, "result cloud");
  const std::vector<double> x = layout.read("x"), y = layout.read("y"), z = layout.read("z"), ux = layout.read("ux"),
                            uy = layout.read("uy"), uz = layout.read("uz"), vm = layout.read("von_mises");
  demnerf::core::ResultField result;
  result.resize(layout.points());
  for (std::size_t i = 0; i < result.size(); ++i) {
    result.displacements[i] = {ux[i], uy[i], uz[i]};
    const Eigen::Vector3d p(x[i], y[i], z[i]);
    result.positions[i] = displaced_positions ? Eigen::Vector3d(p - result.displacements[i]) : p;
    result.von_mises[i] = vm[i];
  }
  result.validate();
  return result;
}

}  // namespace dem_nerf
