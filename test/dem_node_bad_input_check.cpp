// rostest node: dem_node meets bad input (an empty particle cloud, fixtures that select no
// particle, a model it cannot render with), reports each on ~status and in the ~solve response,
// and still answers the next good request.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/Solve.h>
#include <gtest/gtest.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <cstdio>
#include <fstream>

#include "check_helpers.hpp"
#include "conversions/cloud_conversions.hpp"

namespace {

using dem_nerf_test::StatusRecorder;

using dem_nerf_test::halfspace;

// A small downward pull on the bar's free end; the clamp comes from the node's scenario.
dem_nerf::LoadCase tipLoad() {
  dem_nerf::LoadCase load_case;
  load_case.header.frame_id = "world";
  dem_nerf::Load load;
  load.name = "tip";
  load.region = halfspace(0.095, -1.0);  // x >= 0.095
  load.wrench.force.z = -0.002;
  load_case.loads.push_back(load);
  return load_case;
}

dem_nerf::Fixture nowhere() {
  dem_nerf::Fixture fixture;
  fixture.name = "nowhere";
  fixture.region.type = dem_nerf::Region::BOX;
  fixture.region.pose.position.x = 5.0;
  fixture.region.pose.orientation.w = 1.0;
  fixture.region.size.x = fixture.region.size.y = fixture.region.size.z = 0.01;
  return fixture;
}

sensor_msgs::PointCloud2 emptyCloud() {
  std_msgs::Header header;
  header.frame_id = "world";
  header.stamp = ros::Time::now();
  return dem_nerf::toPointCloud2(demnerf::core::ParticleCloud{}, header);  // the fields, no rows
}

class DemNodeBadInput : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService("/dem_node/solve", ros::Duration(20)));
    particles_ = node_.advertise<sensor_msgs::PointCloud2>("/particles", 1, true);
  }

  /// A good load case, solved: the node is alive and its state intact.
  void expectGoodSolve(std::size_t particles) {
    dem_nerf::Solve solve;
    solve.request.load_case = tipLoad();
    ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
    EXPECT_TRUE(solve.response.ok) << solve.response.message;
    EXPECT_EQ(static_cast<std::size_t>(solve.response.displaced.width) * solve.response.displaced.height, particles);
    EXPECT_GT(solve.response.max_displacement, 0.0);
    std::printf("good solve: %s\n", solve.response.message.c_str());
  }

  /// Publishes the bar and waits until a solve sees it.
  void publishBar() {
    std_msgs::Header header;
    header.frame_id = "world";
    header.stamp = ros::Time::now();
    particles_.publish(dem_nerf::toPointCloud2(dem_nerf_test::barParticles(), header));
    ASSERT_TRUE(dem_nerf_test::spinUntil(
        [] {
          dem_nerf::Solve solve;
          solve.request.load_case = tipLoad();
          return ros::service::call("/dem_node/solve", solve) && solve.response.ok;
        },
        30))
        << "dem_node never solved with the bar";
  }

  ros::NodeHandle node_;
  ros::Publisher particles_;
};

TEST_F(DemNodeBadInput, EmptyCloudIsRejectedAndTheLastGoodCloudKept) {
  StatusRecorder status(node_, "/dem_node/status");
  status.mark();
  particles_.publish(emptyCloud());
  EXPECT_NE(status.waitForError("particles rejected: particle cloud is empty", 10), "");
  // The empty cloud did not become the node's particles: the service still says none came.
  dem_nerf::Solve solve;
  solve.request.load_case = tipLoad();
  ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
  EXPECT_FALSE(solve.response.ok);
  EXPECT_NE(solve.response.message.find("no particle cloud"), std::string::npos) << solve.response.message;

  publishBar();
  const std::size_t bar = dem_nerf_test::barParticles().size();
  expectGoodSolve(bar);
  // Empty again, after a good cloud: rejected, and the good cloud stays in use.
  status.mark();
  particles_.publish(emptyCloud());
  EXPECT_NE(status.waitForError("particle cloud is empty", 10), "");
  expectGoodSolve(bar);
}

TEST_F(DemNodeBadInput, FixtureThatSelectsNothingIsRejected) {
  publishBar();
  StatusRecorder status(node_, "/dem_node/status");
  status.mark();
  dem_nerf::Solve solve;
  solve.request.load_case = tipLoad();
  solve.request.load_case.fixtures.push_back(nowhere());
  ASSERT_TRUE(ros::service::call("/dem_node/solve", solve));
  EXPECT_FALSE(solve.response.ok);
  EXPECT_NE(solve.response.message.find("fixture 'nowhere' selects no particles"), std::string::npos)
      << solve.response.message;
  EXPECT_NE(status.waitForError("fixture 'nowhere' selects no particles", 10), "");
  expectGoodSolve(dem_nerf_test::barParticles().size());

  // The same on the ~fixtures topic: rejected there too, and the scenario's clamp stays.
  status.mark();
  ros::Publisher fixtures = node_.advertise<dem_nerf::FixtureArray>("/dem_node/fixtures", 1, true);
  dem_nerf::FixtureArray array;
  array.header.frame_id = "world";
  array.fixtures.push_back(nowhere());
  fixtures.publish(array);
  EXPECT_NE(status.waitForError("fixtures rejected: fixture 'nowhere' selects no particles", 10), "");
  dem_nerf::Solve good;
  good.request.load_case = tipLoad();
  ASSERT_TRUE(ros::service::call("/dem_node/solve", good));
  ASSERT_TRUE(good.response.ok) << good.response.message;
  // The clamped end (x = 0) must not move: the scenario's clamp survived the bad fixture message.
  sensor_msgs::PointCloud2ConstIterator<float> x(good.response.displaced, "x"), u(good.response.displaced, "ux");
  double clamp_max = 0.0, tip_max = 0.0;
  for (; x != x.end(); ++x, ++u) {
    const double moved = Eigen::Vector3d(u[0], u[1], u[2]).norm();
    if (x[0] < 1e-6) clamp_max = std::max(clamp_max, moved);
    if (x[0] > 0.1 - 1e-6) tip_max = std::max(tip_max, moved);
  }
  EXPECT_LT(clamp_max, 1e-6);
  EXPECT_GT(tip_max, 1e-5);
}

TEST_F(DemNodeBadInput, RenderWithoutAUsableModelIsReported) {
  publishBar();
  StatusRecorder status(node_, "/dem_node/status");
  std::size_t images = 0;
  auto rendered = node_.subscribe<sensor_msgs::Image>("/dem_node/rendered", 1,
                                                      [&](const sensor_msgs::ImageConstPtr&) { ++images; });
  ASSERT_TRUE(dem_nerf_test::spinUntil([&] { return rendered.getNumPublishers() > 0; }, 10));
  // No ModelInfo and no ~model_path: a subscriber makes the node try, and it says why it cannot.
  status.mark();
  expectGoodSolve(dem_nerf_test::barParticles().size());
  EXPECT_NE(status.waitForError("no NeRF model to render with", 15), "");

  // A ModelInfo naming a corrupt file.
  const std::string path = "/tmp/dem_node_bad_input_corrupt.nerf";
  {
    std::ofstream file(path, std::ios::binary | std::ios::trunc);
    file << "this is not a NeRF model file, just some garbage bytes \x01\x02\x03";
  }
  ros::Publisher models = node_.advertise<dem_nerf::ModelInfo>("/model", 1, true);
  dem_nerf::ModelInfo info;
  info.header.frame_id = "world";
  info.model_path = path;
  status.mark();
  models.publish(info);
  // Handled, not merely connected: a subscriber count says the latched ModelInfo is on its way,
  // not that onModel has run, and the render errors of the part above ("no NeRF model") may still
  // come after the mark. The node's own signal: with a result in hand and a listener on ~rendered,
  // onModel renders again, and that render's error names the file.
  EXPECT_TRUE(status.waitUntil(
      [&](const dem_nerf::TrainingStatus& s) {
        return s.stage == "error" && s.message.find("~rendered not updated") != std::string::npos &&
               s.message.find(path) != std::string::npos;
      },
      15))
      << "no render error naming " << path << " after the ModelInfo";
  // The node now holds the model, and renders run one at a time: the first render error after a
  // solve names the file too.
  status.mark();
  expectGoodSolve(dem_nerf_test::barParticles().size());
  const std::string message = status.waitForError("~rendered not updated", 15);
  EXPECT_NE(message.find(path), std::string::npos) << "the error should name the file: " << message;
  EXPECT_EQ(images, 0u) << "nothing renderable, yet an image came";
  // Still alive and solving.
  expectGoodSolve(dem_nerf_test::barParticles().size());
  std::remove(path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "dem_node_bad_input_check");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
