#pragma once
// The nodes' fuzz check's message generators (nodes_fuzz_check.cpp): seeded mutation primitives,
// valid messages of every type the nodes take, and their mutants.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/TrainingStatus.h>
#include <geometry_msgs/WrenchStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>

#include "check_helpers.hpp"
#include "conversions/cloud_conversions.hpp"

namespace dem_nerf_fuzz {

using Rng = std::mt19937_64;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- the seeded mutation primitives -------------------------------------------------------------

inline double pick(Rng& rng, std::initializer_list<double> values) {
  std::uniform_int_distribution<std::size_t> index(0, values.size() - 1);
  return *(values.begin() + index(rng));
}
inline int below(Rng& rng, int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); }
inline bool coin(Rng& rng) { return below(rng, 2) == 0; }
/// A number an attacker would try: NaN, Inf, huge, tiny, negative, zero, or a small change.
inline double evil(Rng& rng, double good) {
  return pick(rng, {kNan, kInf, -kInf, 1e30, -1e30, 1e-300, 0.0, -good, good * 1e6, good + 1e-3,
                    static_cast<double>(std::numeric_limits<float>::max()), 4e9});
}
inline std::uint32_t evilSize(Rng& rng, std::uint32_t good) {
  return static_cast<std::uint32_t>(
      pick(rng, {0.0, 1.0, 2.0, double(good) + 1, double(good) - 1, double(good) * 2, 65535, 65536, 65537,
                 2147483648.0, 4294967295.0, 4e9}));
}
inline std::string evilFrame(Rng& rng) {
  const char* frames[] = {"", "world", "tool", "no_such_frame", "/world", "world ", "camera_optical", "\x01\x02"};
  return frames[below(rng, 8)];
}

// ---- valid messages, and their mutants ------------------------------------------------------

inline std_msgs::Header worldHeader() {
  std_msgs::Header header;
  header.frame_id = "world";
  header.stamp = ros::Time::now();
  return header;
}

inline sensor_msgs::PointCloud2 barCloud() { return dem_nerf::toPointCloud2(dem_nerf_test::barParticles(), worldHeader()); }

inline sensor_msgs::PointCloud2 mutateCloud(Rng& rng) {
  sensor_msgs::PointCloud2 m = barCloud();
  const int mutations = 1 + below(rng, 3);
  for (int k = 0; k < mutations; ++k) {
    const int kind = below(rng, 12);
    if (m.fields.empty() && kind >= 5 && kind <= 8) continue;  // nothing left to mutate there
    if (m.data.size() < 4 && kind == 9) continue;
    switch (kind) {
      case 0: m.width = evilSize(rng, m.width); break;
      case 1: m.height = evilSize(rng, m.height); break;
      case 2: m.point_step = evilSize(rng, m.point_step); break;
      case 3: m.row_step = evilSize(rng, m.row_step); break;
      case 4: m.data.resize(below(rng, 3) == 0 ? 0 : m.data.size() / (1 + below(rng, 4))); break;
      case 5: m.fields[below(rng, static_cast<int>(m.fields.size()))].offset = evilSize(rng, 4); break;
      case 6: m.fields[below(rng, static_cast<int>(m.fields.size()))].datatype = static_cast<std::uint8_t>(below(rng, 12)); break;
      case 7: m.fields[below(rng, static_cast<int>(m.fields.size()))].count = evilSize(rng, 1); break;
      case 8: m.fields.erase(m.fields.begin() + below(rng, static_cast<int>(m.fields.size()))); break;
      case 9: {  // NaN, Inf or huge coordinates in the data
        const float value = static_cast<float>(evil(rng, 0.05));
        const std::size_t at = 4 * static_cast<std::size_t>(below(rng, static_cast<int>(m.data.size() / 4)));
        std::memcpy(&m.data[at], &value, sizeof(value));
        break;
      }
      case 10: m.header.frame_id = evilFrame(rng); break;
      case 11: m.is_bigendian = coin(rng); break;
    }
  }
  return m;
}

inline dem_nerf::Region goodRegion() { return dem_nerf_test::halfspace(0.005, 1.0); }  // x <= 0.005: the clamp

inline void mutateRegion(Rng& rng, dem_nerf::Region& region) {
  switch (below(rng, 8)) {
    case 0: region.type = static_cast<std::uint8_t>(below(rng, 256)); break;  // unknown enums
    case 1: region.pose.position.x = evil(rng, 0.05); break;
    case 2: region.size.x = evil(rng, 0.01); region.type = dem_nerf::Region::BOX; break;
    case 3: region.radius = evil(rng, 0.01); region.type = dem_nerf::Region::SPHERE; break;
    case 4: region.normal.x = region.normal.y = region.normal.z = coin(rng) ? 0.0 : kNan; break;
    case 5:  // a box that holds every particle (a crash of issue 14)
      region.type = dem_nerf::Region::BOX;
      region.pose.position.x = 0.05;
      region.size.x = region.size.y = region.size.z = 1.0;
      break;
    case 6:  // a box that holds one corner particle: almost nothing fixed
      region.type = dem_nerf::Region::BOX;
      region.pose.position.x = 0.0;
      region.pose.position.y = region.pose.position.z = -0.01;
      region.size.x = region.size.y = region.size.z = 0.001;
      break;
    case 7: region.pose.orientation.w = evil(rng, 1.0); break;
  }
}

inline dem_nerf::Fixture clampFixture() {
  dem_nerf::Fixture fixture;
  fixture.name = "clamp";
  fixture.region = goodRegion();
  return fixture;
}

inline dem_nerf::Load tipLoad(double fz = -0.002) {
  dem_nerf::Load load;
  load.name = "tip";
  load.region = dem_nerf_test::halfspace(0.095, -1.0);  // x >= 0.095
  load.wrench.force.z = fz;
  return load;
}

inline dem_nerf::LoadCase goodLoadCase() {
  dem_nerf::LoadCase load_case;
  load_case.header.frame_id = "world";
  load_case.fixtures = {clampFixture()};
  load_case.loads = {tipLoad()};
  return load_case;
}

inline dem_nerf::LoadCase mutateLoadCase(Rng& rng) {
  dem_nerf::LoadCase m = goodLoadCase();
  const int mutations = 1 + below(rng, 3);
  for (int k = 0; k < mutations; ++k) {
    const int kind = below(rng, 9);
    if ((m.fixtures.empty() && (kind == 0 || kind == 7)) || (m.loads.empty() && (kind == 1 || kind == 4 || kind == 5)))
      continue;  // cleared by an earlier mutation
    switch (kind) {
      case 0: mutateRegion(rng, m.fixtures[0].region); break;
      case 1: mutateRegion(rng, m.loads[0].region); break;
      case 2: m.fixtures.clear(); break;
      case 3: m.loads.clear(); break;
      case 4: m.loads[0].wrench.force.z = evil(rng, 0.002); break;
      case 5: m.loads[0].wrench.torque.x = evil(rng, 0.0001); break;
      case 6: m.body_force.z = evil(rng, 10.0); break;
      case 7: m.fixtures[0].displacement.x = evil(rng, 0.001); break;
      case 8: m.header.frame_id = evilFrame(rng); break;
    }
  }
  return m;
}

inline geometry_msgs::WrenchStamped mutateWrench(Rng& rng) {
  geometry_msgs::WrenchStamped w;
  w.header.frame_id = "tool";
  w.wrench.force.z = -0.002;
  const int mutations = 1 + below(rng, 2);
  for (int k = 0; k < mutations; ++k) {
    switch (below(rng, 5)) {
      case 0: w.wrench.force.x = evil(rng, 0.002); break;
      case 1: w.wrench.torque.z = evil(rng, 0.0001); break;
      case 2: w.header.frame_id = evilFrame(rng); break;
      case 3: w.wrench = geometry_msgs::Wrench(); break;  // zero wrench
      case 4: w.header.stamp = ros::Time(1e9 * (1 + below(rng, 3))); break;  // far-off stamps
    }
  }
  return w;
}

inline sensor_msgs::CameraInfo cameraInfo(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "camera_optical";
  info.width = width;
  info.height = height;
  info.K = {10, 0, width / 2.0, 0, 10, height / 2.0, 0, 0, 1};
  return info;
}

inline sensor_msgs::CameraInfo mutateCameraInfo(Rng& rng) {
  sensor_msgs::CameraInfo info = cameraInfo(8, 6);
  switch (below(rng, 6)) {
    case 0: info.width = evilSize(rng, 8); break;
    case 1: info.height = evilSize(rng, 6); break;
    case 2: info.K[below(rng, 9)] = evil(rng, 10); break;
    case 3: info.D = std::vector<double>(below(rng, 20), evil(rng, 0.1)); info.distortion_model = "plumb_bob"; break;
    case 4: info.distortion_model = "fisheye_unknown"; info.D = {0.1}; break;
    case 5: info.K = {}; break;
  }
  return info;
}

inline sensor_msgs::Image goodImage(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::Image image;
  image.header.frame_id = "camera_optical";
  image.width = width;
  image.height = height;
  image.encoding = "rgb8";
  image.step = width * 3;
  image.data.assign(static_cast<std::size_t>(image.step) * height, 128);
  return image;
}

inline void mutateImage(Rng& rng, sensor_msgs::Image& image, sensor_msgs::CameraInfo& info) {
  const int mutations = 1 + below(rng, 2);
  for (int k = 0; k < mutations; ++k) {
    switch (below(rng, 8)) {
      case 0: image.width = info.width = evilSize(rng, image.width); break;
      case 1: image.height = info.height = evilSize(rng, image.height); break;
      case 2: image.step = evilSize(rng, image.step); break;
      case 3: image.data.resize(below(rng, 3) == 0 ? 0 : image.data.size() / (1 + below(rng, 3))); break;
      case 4: {
        const char* encodings[] = {"mono8", "rgba8", "bgr8", "bgra8", "32FC1", "16UC1", "bayer_rggb8", "", "yuv422"};
        image.encoding = encodings[below(rng, 9)];
        break;
      }
      case 5: image.width = evilSize(rng, image.width); break;  // image and camera_info disagree
      case 6: image.is_bigendian = 1; break;
      case 7: info.K[0] = evil(rng, 10); break;
    }
  }
}


}  // namespace dem_nerf_fuzz
