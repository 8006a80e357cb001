// rostest node (issue 14): nerf_node and dem_node under attack. First the exact inputs that used
// to kill a node (fixed cases), then a seeded generator that mutates valid messages of every
// subscribed type and valid requests of every service (sizes, steps, offsets, datatypes, NaN/Inf,
// huge values, empty arrays, unknown enums, frames). After each batch both nodes must be alive
// and answer a good request, and the refusals must show up counted by cause on ~status.

#include <dem_nerf/ExtractParticles.h>
#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/LoadModel.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/RenderView.h>
#include <dem_nerf/SaveModel.h>
#include <dem_nerf/Solve.h>
#include <geometry_msgs/WrenchStamped.h>
#include <gtest/gtest.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "check_helpers.hpp"
#include "conversions/cloud_conversions.hpp"

namespace {

using dem_nerf_test::StatusRecorder;
using Rng = std::mt19937_64;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- the seeded mutation primitives -------------------------------------------------------------

double pick(Rng& rng, std::initializer_list<double> values) {
  std::uniform_int_distribution<std::size_t> index(0, values.size() - 1);
  return *(values.begin() + index(rng));
}
int below(Rng& rng, int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); }
bool coin(Rng& rng) { return below(rng, 2) == 0; }
/// A number an attacker would try: NaN, Inf, huge, tiny, negative, zero, or a small change.
double evil(Rng& rng, double good) {
  return pick(rng, {kNan, kInf, -kInf, 1e30, -1e30, 1e-300, 0.0, -good, good * 1e6, good + 1e-3,
                    static_cast<double>(std::numeric_limits<float>::max()), 4e9});
}
std::uint32_t evilSize(Rng& rng, std::uint32_t good) {
  return static_cast<std::uint32_t>(
      pick(rng, {0.0, 1.0, 2.0, double(good) + 1, double(good) - 1, double(good) * 2, 65535, 65536, 65537,
                 2147483648.0, 4294967295.0, 4e9}));
}
std::string evilFrame(Rng& rng) {
  const char* frames[] = {"", "world", "tool", "no_such_frame", "/world", "world ", "camera_optical", "\x01\x02"};
  return frames[below(rng, 8)];
}

// ---- valid messages, and their mutants ------------------------------------------------------

std_msgs::Header worldHeader() {
  std_msgs::Header header;
  header.frame_id = "world";
  header.stamp = ros::Time::now();
  return header;
}

sensor_msgs::PointCloud2 barCloud() { return dem_nerf::toPointCloud2(dem_nerf_test::barParticles(), worldHeader()); }

sensor_msgs::PointCloud2 mutateCloud(Rng& rng) {
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

dem_nerf::Region goodRegion() { return dem_nerf_test::halfspace(0.005, 1.0); }  // x <= 0.005: the clamp

void mutateRegion(Rng& rng, dem_nerf::Region& region) {
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

dem_nerf::Fixture clampFixture() {
  dem_nerf::Fixture fixture;
  fixture.name = "clamp";
  fixture.region = goodRegion();
  return fixture;
}

dem_nerf::Load tipLoad(double fz = -0.002) {
  dem_nerf::Load load;
  load.name = "tip";
  load.region = dem_nerf_test::halfspace(0.095, -1.0);  // x >= 0.095
  load.wrench.force.z = fz;
  return load;
}

dem_nerf::LoadCase goodLoadCase() {
  dem_nerf::LoadCase load_case;
  load_case.header.frame_id = "world";
  load_case.fixtures = {clampFixture()};
  load_case.loads = {tipLoad()};
  return load_case;
}

dem_nerf::LoadCase mutateLoadCase(Rng& rng) {
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

geometry_msgs::WrenchStamped mutateWrench(Rng& rng) {
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

sensor_msgs::CameraInfo cameraInfo(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "camera_optical";
  info.width = width;
  info.height = height;
  info.K = {10, 0, width / 2.0, 0, 10, height / 2.0, 0, 0, 1};
  return info;
}

sensor_msgs::CameraInfo mutateCameraInfo(Rng& rng) {
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

sensor_msgs::Image goodImage(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::Image image;
  image.header.frame_id = "camera_optical";
  image.width = width;
  image.height = height;
  image.encoding = "rgb8";
  image.step = width * 3;
  image.data.assign(static_cast<std::size_t>(image.step) * height, 128);
  return image;
}

void mutateImage(Rng& rng, sensor_msgs::Image& image, sensor_msgs::CameraInfo& info) {
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

// ---- the check -----------------------------------------------------------------------------

std::uint32_t rejectionsOf(const dem_nerf::TrainingStatus& status, const std::string& cause) {
  for (const auto& item : status.rejections)
    if (item.cause == cause) return item.count;
  return 0;
}
std::uint32_t rejectionTotal(const dem_nerf::TrainingStatus& status) {
  std::uint32_t total = 0;
  for (const auto& item : status.rejections) total += item.count;
  return total;
}

class NodesFuzz : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(ros::service::waitForService("/dem_node/solve", ros::Duration(30)));
    ASSERT_TRUE(ros::service::waitForService("/nerf_node/render", ros::Duration(30)));
  }

  void SetUp() override {
    tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    dem_nerf_test::broadcastToolFrame(*tf_);
    geometry_msgs::TransformStamped camera;
    camera.header.stamp = ros::Time(0);
    camera.header.frame_id = "world";
    camera.child_frame_id = "camera_optical";
    camera.transform.translation.z = 0.5;
    camera.transform.rotation.w = 1.0;
    tf_->sendTransform(camera);
    particles_ = node_.advertise<sensor_msgs::PointCloud2>("/particles", 1, true);
    fixtures_ = node_.advertise<dem_nerf::FixtureArray>("/dem_node/fixtures", 10);
    wrench_ = node_.advertise<geometry_msgs::WrenchStamped>("/dem_node/wrench", 10);
    load_case_ = node_.advertise<dem_nerf::LoadCase>("/dem_node/load_case", 10);
    model_ = node_.advertise<dem_nerf::ModelInfo>("/model", 10);
    render_info_ = node_.advertise<sensor_msgs::CameraInfo>("/dem_node/render_camera_info", 10);
    images_ = node_.advertise<sensor_msgs::Image>("/camera/image_raw", 10);
    infos_ = node_.advertise<sensor_msgs::CameraInfo>("/camera/camera_info", 10);
    ASSERT_TRUE(dem_nerf_test::spinUntil(
        [&] {
          return particles_.getNumSubscribers() > 0 && fixtures_.getNumSubscribers() > 0 &&
                 wrench_.getNumSubscribers() > 0 && load_case_.getNumSubscribers() > 0 &&
                 images_.getNumSubscribers() > 0 && infos_.getNumSubscribers() > 0 &&
                 render_info_.getNumSubscribers() > 0 && model_.getNumSubscribers() > 0;
        },
        20));
    restoreGoodState();
  }

  /// The bar and the clamp again (a valid mutant may have replaced them), until a solve sees them.
  void restoreGoodState() {
    particles_.publish(barCloud());
    dem_nerf::FixtureArray clamp;
    clamp.header.frame_id = "world";
    clamp.fixtures = {clampFixture()};
    fixtures_.publish(clamp);
    ASSERT_TRUE(dem_nerf_test::spinUntil([&] { return goodSolve(false); }, 30)) << "dem_node lost the bar";
  }

  /// A good ~solve answers with the bar, displaced.
  bool goodSolve(bool report = true) {
    dem_nerf::Solve solve;
    solve.request.load_case = goodLoadCase();
    if (!ros::service::call("/dem_node/solve", solve)) {
      if (report) ADD_FAILURE() << "dem_node's ~solve did not answer (is the node dead?)";
      return false;
    }
    const bool ok = solve.response.ok &&
                    solve.response.displaced.width * solve.response.displaced.height ==
                        dem_nerf_test::barParticles().size() &&
                    solve.response.max_displacement > 0;
    if (report) EXPECT_TRUE(ok) << solve.response.message;
    return ok;
  }

  /// Both nodes alive: dem_node solves a good request; nerf_node answers ~render and ~save with
  /// their clear "no model yet" reasons; both keep publishing ~status.
  void expectBothAlive(const std::string& after) {
    SCOPED_TRACE("after " + after);
    restoreGoodState();
    EXPECT_TRUE(goodSolve());
    dem_nerf::RenderView render;
    render.request.camera_info = cameraInfo(8, 6);
    render.request.pose.orientation.w = 1.0;
    ASSERT_TRUE(ros::service::call("/nerf_node/render", render)) << "nerf_node's ~render did not answer";
    EXPECT_NE(render.response.message, "");
    dem_nerf::SaveModel save;
    ASSERT_TRUE(ros::service::call("/nerf_node/save", save)) << "nerf_node's ~save did not answer";
    EXPECT_NE(save.response.message.find("nothing to save"), std::string::npos) << save.response.message;
    StatusRecorder dem(node_, "/dem_node/status"), nerf(node_, "/nerf_node/status");
    dem.mark();
    nerf.mark();
    const auto any = [](const dem_nerf::TrainingStatus&) { return true; };
    EXPECT_TRUE(dem.waitUntil(any, 5)) << "no ~status from dem_node";
    EXPECT_TRUE(nerf.waitUntil(any, 5)) << "no ~status from nerf_node";
  }

  /// The latest ~status of a node.
  dem_nerf::TrainingStatus latestStatus(const std::string& node) {
    StatusRecorder recorder(node_, "/" + node + "/status");
    recorder.mark();
    dem_nerf::TrainingStatus status;
    EXPECT_TRUE(recorder.waitUntil([](const dem_nerf::TrainingStatus&) { return true; }, 5, &status));
    return status;
  }

  template <typename Message>
  void publishPaced(ros::Publisher& publisher, const Message& message) {
    publisher.publish(message);
    ros::WallDuration(0.004).sleep();
  }

  void publishImagePair(sensor_msgs::Image image, sensor_msgs::CameraInfo info) {
    image.header.stamp = info.header.stamp = ros::Time::now();
    info.header.frame_id = image.header.frame_id;
    images_.publish(image);
    infos_.publish(info);
    ros::WallDuration(0.01).sleep();
  }

  ros::NodeHandle node_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_;
  ros::Publisher particles_, fixtures_, wrench_, load_case_, model_, render_info_, images_, infos_;
};

// ---- issue 14's reproducers, each followed by a good request --------------------------------

TEST_F(NodesFuzz, IssueReproducersAreRefusedAndBothNodesLive) {
  StatusRecorder nerf(node_, "/nerf_node/status"), dem(node_, "/dem_node/status");
  // nerf_node: mono8 1 x 65537 with step 65536 and 65536 bytes (cv_bridge's 32-bit check wraps).
  nerf.mark();
  {
    sensor_msgs::Image image;
    image.header.frame_id = "camera_optical";
    image.encoding = "mono8";
    image.width = 1;
    image.height = 65537;
    image.step = 65536;
    image.data.assign(65536, 7);
    bool reported = false;
    for (int attempt = 0; attempt < 10 && !reported; ++attempt) {
      publishImagePair(image, cameraInfo(1, 65537));
      reported = !nerf.waitForError("step x height", 1.5).empty();
    }
    EXPECT_TRUE(reported) << "the wrapped-size image was not refused by its 64-bit size";
    // mono8 65536 x 65536, step 65536, no data (an uncaught cv::Exception before).
    image.width = image.height = 65536;
    image.data.clear();
    reported = false;
    for (int attempt = 0; attempt < 10 && !reported; ++attempt) {
      publishImagePair(image, cameraInfo(65536, 65536));
      reported = !nerf.waitForError("pixels accepted", 1.5).empty();
    }
    EXPECT_TRUE(reported);
  }
  // dem_node: width 525, point_step 0, empty data, float32 fields x y z volume nx ny nz area.
  dem.mark();
  {
    demnerf::core::ParticleCloud cloud;
    cloud.resize(525);
    sensor_msgs::PointCloud2 m = dem_nerf::toPointCloud2(cloud, worldHeader());
    m.fields.pop_back();  // no rgb: the issue's field list
    m.point_step = 0;
    m.row_step = 0;
    m.data.clear();
    particles_.publish(m);
    EXPECT_NE(dem.waitForError("point_step 0", 10), "");
    m = dem_nerf::toPointCloud2(cloud, worldHeader());  // a field offset of 4e9
    m.fields[1].offset = 4000000000u;
    dem.mark();
    particles_.publish(m);
    EXPECT_NE(dem.waitForError("does not fit in point_step", 10), "");
  }
  restoreGoodState();
  // A fixture box that holds every particle, plus a load: three routes, each refused.
  dem_nerf::Fixture everything = clampFixture();
  everything.region.type = dem_nerf::Region::BOX;
  everything.region.pose.position.x = 0.05;
  everything.region.size.x = everything.region.size.y = everything.region.size.z = 1.0;
  dem_nerf::Solve solve;
  solve.request.load_case = goodLoadCase();
  solve.request.load_case.fixtures = {everything};
  ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
  EXPECT_FALSE(solve.response.ok);
  EXPECT_NE(solve.response.message.find("every one of the"), std::string::npos) << solve.response.message;
  dem.mark();
  dem_nerf::LoadCase all = solve.request.load_case;
  load_case_.publish(all);
  EXPECT_NE(dem.waitForError("nothing is left to solve", 15), "");
  dem.mark();
  dem_nerf::FixtureArray array;
  array.header.frame_id = "world";
  array.fixtures = {everything};
  fixtures_.publish(array);
  geometry_msgs::WrenchStamped wrench;
  wrench.header.frame_id = "tool";
  wrench.wrench.force.z = -0.002;
  ros::WallDuration(0.3).sleep();
  wrench_.publish(wrench);
  EXPECT_NE(dem.waitForError("nothing is left to solve", 15), "");
  // One pinned particle plus the tip load: an almost free body, refused as degenerate.
  solve.request.load_case = goodLoadCase();
  solve.request.load_case.fixtures[0].region.type = dem_nerf::Region::BOX;
  solve.request.load_case.fixtures[0].region.pose.position.x = 0.0;
  solve.request.load_case.fixtures[0].region.pose.position.y = -0.01;
  solve.request.load_case.fixtures[0].region.pose.position.z = -0.01;
  solve.request.load_case.fixtures[0].region.size.x = solve.request.load_case.fixtures[0].region.size.y =
      solve.request.load_case.fixtures[0].region.size.z = 0.001;
  ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
  EXPECT_FALSE(solve.response.ok);
  EXPECT_NE(solve.response.message.find("rigid-body"), std::string::npos) << solve.response.message;
  // A zero load answers zero displacement (on ~solve and on ~wrench alike).
  solve.request.load_case = goodLoadCase();
  solve.request.load_case.loads[0].wrench.force.z = 0.0;
  ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
  EXPECT_TRUE(solve.response.ok) << solve.response.message;
  EXPECT_EQ(solve.response.max_displacement, 0.0);
  restoreGoodState();
  dem.mark();
  wrench.wrench = geometry_msgs::Wrench();
  wrench_.publish(wrench);
  EXPECT_TRUE(dem.waitUntil(
      [](const dem_nerf::TrainingStatus& s) {
        return s.last_solve.cause == "wrench" && s.last_solve.answered_by == dem_nerf::SolveAnswer::NO_LOAD;
      },
      15))
      << "a zero wrench is answered with zero displacement";
  // An empty FixtureArray clears the fixtures: the next solve is refused for want of supports.
  dem.mark();
  array.fixtures.clear();
  fixtures_.publish(array);
  EXPECT_NE(dem.waitFor("", "fixtures cleared", 10), "");
  wrench.wrench.force.z = -0.002;
  wrench_.publish(wrench);
  EXPECT_NE(dem.waitForError("has no fixture", 15), "");
  // A 2,086,875-particle cloud: refused by ~max_particles before it is converted.
  dem.mark();
  {
    sensor_msgs::PointCloud2 big = barCloud();
    big.width = 2086875;
    big.row_step = big.width * big.point_step;
    big.data.assign(static_cast<std::size_t>(big.row_step), 0);
    particles_.publish(big);
  }
  EXPECT_NE(dem.waitForError("more than the limit", 20), "");
  // ~render 4000 x 4000 and 20000 x 20000: refused at once by ~max_render_pixels.
  for (const std::uint32_t side : {4000u, 20000u}) {
    dem_nerf::RenderView render;
    render.request.camera_info = cameraInfo(side, side);
    render.request.pose.orientation.w = 1.0;
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(ros::service::call("/nerf_node/render", render));
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 2.0);
    EXPECT_FALSE(render.response.ok);
  }
  // ~load of a 1 GiB file that is not a model: refused by its header, without reading it.
  {
    const std::string path = "/tmp/nodes_fuzz_check_1gib.nerf";
    { std::ofstream file(path, std::ios::binary | std::ios::trunc); }
    std::filesystem::resize_file(path, 1ull << 30);  // sparse: no disk used
    dem_nerf::LoadModel load;
    load.request.path = path;
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(ros::service::call("/nerf_node/load", load));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::remove(path.c_str());
    EXPECT_FALSE(load.response.ok);
    EXPECT_NE(load.response.message.find("wrong magic bytes"), std::string::npos) << load.response.message;
    EXPECT_LT(seconds, 1.0) << "the whole file was read before its magic bytes were checked";
  }
  expectBothAlive("the reproducers");
  // Every refusal above is counted by cause in numeric fields.
  const dem_nerf::TrainingStatus dem_status = latestStatus("dem_node");
  EXPECT_GE(rejectionsOf(dem_status, "particles"), 3u);
  EXPECT_GE(rejectionsOf(dem_status, "solve_degenerate"), 3u);
  EXPECT_DOUBLE_EQ(dem_status.solve.time_limit, 10.0);  // ~solve_time_limit, as launched
  const dem_nerf::TrainingStatus nerf_status = latestStatus("nerf_node");
  EXPECT_GE(rejectionsOf(nerf_status, "image"), 2u);
  EXPECT_GE(rejectionsOf(nerf_status, "render"), 2u);
  EXPECT_GE(rejectionsOf(nerf_status, "load"), 1u);
}

// ---- seeded mutation batches --------------------------------------------------------------------

constexpr std::uint64_t kSeed = 14;

TEST_F(NodesFuzz, MutatedTopicMessages) {
  Rng rng(kSeed);
  const auto before = latestStatus("dem_node");
  for (int i = 0; i < 300; ++i) publishPaced(particles_, mutateCloud(rng));
  expectBothAlive("300 mutated PointCloud2 on particles");
  for (int i = 0; i < 300; ++i) {
    dem_nerf::FixtureArray array;
    array.header.frame_id = "world";
    const int count = below(rng, 4);
    for (int k = 0; k < count; ++k) {
      dem_nerf::Fixture fixture = clampFixture();
      mutateRegion(rng, fixture.region);
      if (coin(rng)) fixture.displacement.z = evil(rng, 0.001);
      array.fixtures.push_back(fixture);
    }
    if (coin(rng)) array.header.frame_id = evilFrame(rng);
    publishPaced(fixtures_, array);
  }
  expectBothAlive("300 mutated FixtureArray");
  for (int i = 0; i < 300; ++i) publishPaced(wrench_, mutateWrench(rng));
  expectBothAlive("300 mutated WrenchStamped");
  for (int i = 0; i < 300; ++i) publishPaced(load_case_, mutateLoadCase(rng));
  expectBothAlive("300 mutated LoadCase");
  for (int i = 0; i < 300; ++i) {
    dem_nerf::ModelInfo info;
    info.header.frame_id = evilFrame(rng);
    const char* paths[] = {"", "/nonexistent.nerf", "/dev/zero", "/", "relative.nerf", "/proc/self/mem"};
    info.model_path = paths[below(rng, 6)];
    info.aabb_min.x = evil(rng, -1);
    publishPaced(model_, info);
    publishPaced(render_info_, mutateCameraInfo(rng));
  }
  expectBothAlive("300 mutated ModelInfo and render CameraInfo");
  for (int i = 0; i < 300; ++i) {
    sensor_msgs::Image image = goodImage(8, 6);
    sensor_msgs::CameraInfo info = coin(rng) ? cameraInfo(8, 6) : mutateCameraInfo(rng);
    mutateImage(rng, image, info);
    publishImagePair(image, info);
  }
  expectBothAlive("300 mutated Image + CameraInfo pairs");
  const auto after = latestStatus("dem_node");
  EXPECT_GT(rejectionTotal(after), rejectionTotal(before) + 100) << "the refusals must be counted on ~status";
  EXPECT_GT(rejectionTotal(latestStatus("nerf_node")), 50u);
}

TEST_F(NodesFuzz, MutatedServiceRequests) {
  Rng rng(kSeed + 1);
  for (int i = 0; i < 100; ++i) {
    dem_nerf::Solve solve;
    solve.request.load_case = mutateLoadCase(rng);
    ASSERT_TRUE(ros::service::call("/dem_node/solve", solve)) << "case " << i;
    if (!solve.response.ok) EXPECT_NE(solve.response.message, "") << "case " << i;
  }
  expectBothAlive("100 mutated ~solve requests");
  for (int i = 0; i < 200; ++i) {
    dem_nerf::RenderView render;
    render.request.camera_info = mutateCameraInfo(rng);
    render.request.pose.orientation.w = coin(rng) ? 1.0 : evil(rng, 1.0);
    render.request.pose.position.x = coin(rng) ? 0.0 : evil(rng, 0.1);
    ASSERT_TRUE(ros::service::call("/nerf_node/render", render)) << "case " << i;
    EXPECT_NE(render.response.message, "");
  }
  for (int i = 0; i < 40; ++i) {
    dem_nerf::ExtractParticles extract;
    const char* samplers[] = {"", "grid", "poisson", "random", "nonsense"};
    extract.request.sampler = samplers[below(rng, 5)];
    extract.request.spacing = evil(rng, 0.01);
    ASSERT_TRUE(ros::service::call("/nerf_node/extract", extract));
    EXPECT_FALSE(extract.response.ok);  // no model yet
  }
  for (int i = 0; i < 60; ++i) {
    dem_nerf::LoadModel load;
    const char* paths[] = {"", "/", "/dev/null", "/nonexistent/model.nerf", "/proc/self/status", "\x01"};
    load.request.path = paths[below(rng, 6)];
    ASSERT_TRUE(ros::service::call("/nerf_node/load", load));
    EXPECT_FALSE(load.response.ok);
    dem_nerf::SaveModel save;
    save.request.path = paths[below(rng, 6)];
    ASSERT_TRUE(ros::service::call("/nerf_node/save", save));
    EXPECT_FALSE(save.response.ok);
  }
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call("/nerf_node/reset", reset));
  expectBothAlive("mutated ~render, ~extract, ~load, ~save, ~reset requests");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodes_fuzz_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
