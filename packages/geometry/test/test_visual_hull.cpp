#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/object_isolation.hpp"
#include "demnerf/geometry/solid_body.hpp"
#include "demnerf/geometry/visual_hull.hpp"

namespace demnerf::geometry {
namespace {

// A ball of radius 0.3 at the origin in the box [-0.4, 0.4]^3, its density rising with depth
// (2.5 at the surface) so the extracted surface lies where the ball is.
constexpr double kBall = 0.3, kLevel = 2.5;
const Eigen::AlignedBox3d kBox(Eigen::Vector3d::Constant(-0.4), Eigen::Vector3d::Constant(0.4));
constexpr int kResolution = 48;  // cells of 0.0167

DensityGrid ballGrid() {
  const DensityFunction ball = [](const float* points, std::int64_t n, float* sigma) {
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
      sigma[i] = static_cast<float>(kLevel + 1000.0 * (kBall - p.norm()));
    }
  };
  return sampleDensityInBox(ball, kBox, kResolution);
}

// A 60-degree pinhole camera 2.5 away from the origin along `direction`, looking at it; its
// 200 x 200 image holds the whole box.
ViewCamera cameraFrom(const Eigen::Vector3d& direction) {
  ViewCamera view;
  view.camera.width = view.camera.height = 200;
  view.camera.fx = view.camera.fy = 100.0 / std::tan(M_PI / 6.0);
  view.camera.cx = view.camera.cy = 100.0;
  const Eigen::Vector3d z = -direction.normalized();  // optical axis, towards the origin
  const Eigen::Vector3d helper = std::abs(z.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x = helper.cross(z).normalized(), y = z.cross(x);
  view.world_from_camera.linear().col(0) = x;
  view.world_from_camera.linear().col(1) = y;
  view.world_from_camera.linear().col(2) = z;
  view.world_from_camera.translation() = 2.5 * direction.normalized();
  return view;
}

// Whether the segment from the camera to p passes within `radius` of the origin.
bool blockedByBall(const ViewCamera& view, const Eigen::Vector3d& p, double radius) {
  const Eigen::Vector3d c = view.world_from_camera.translation(), d = p - c;
  const double t = std::clamp(-c.dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (c + t * d).norm() < radius;
}

// A camera straight in front (+x) and four tilted 50 degrees off it: a one-sided capture.
std::vector<ViewCamera> frontCameras() {
  std::vector<ViewCamera> views{cameraFrom(Eigen::Vector3d::UnitX())};
  const double c = std::cos(50.0 * M_PI / 180.0), s = std::sin(50.0 * M_PI / 180.0);
  const Eigen::Vector3d sides[] = {Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
                                   -Eigen::Vector3d::UnitZ()};
  for (const Eigen::Vector3d& side : sides) views.push_back(cameraFrom(c * Eigen::Vector3d::UnitX() + s * side));
  return views;
}

TEST(VisualHull, BallSeenFromOneSideFillsItsShadowOnly) {
  const DensityGrid grid = ballGrid();
  const std::vector<ViewCamera> views = frontCameras();
  SolidConfig config;
  config.cameras = views;
  SolidReport report;
  const DensityGrid solid = solidifyField(grid, kLevel, config, &report);
  EXPECT_GT(report.hidden_nodes, 0u);
  const double h = grid.spacing.maxCoeff();
  const Eigen::Vector3i& n = grid.dims;
  int filled_checked = 0, empty_checked = 0;
  for (int k = 1; k + 1 < n.z(); ++k)
    for (int j = 1; j + 1 < n.y(); ++j)
      for (int i = 1; i + 1 < n.x(); ++i) {
        const Eigen::Vector3d p = grid.node(i, j, k);
        const bool filled = solid.at(i, j, k) > kLevel;
        if (p.norm() < kBall + 2 * h) continue;  // the ball itself and its surface's stair-steps
        // Every camera has the whole box in view, so filled means: the ball hides it from each
        // (within a cell's tolerance on the silhouette), and empty means some camera sees it.
        bool hidden_from_all = true, hidden_from_all_loosely = true;
        for (const ViewCamera& view : views) {
          hidden_from_all = hidden_from_all && blockedByBall(view, p, kBall - 2 * h);
          hidden_from_all_loosely = hidden_from_all_loosely && blockedByBall(view, p, kBall + 2 * h);
        }
        if (filled) {
          EXPECT_TRUE(hidden_from_all_loosely) << "filled node " << p.transpose() << " is in plain view";
          ++filled_checked;
        } else {
          EXPECT_FALSE(hidden_from_all) << "node " << p.transpose() << " no camera sees was left empty";
          ++empty_checked;
        }
      }
  EXPECT_GT(filled_checked, 100);
  EXPECT_GT(empty_checked, 1000);
  // Straight behind the ball is filled; beside it, where the tilted cameras look, is not.
  EXPECT_GT(solid.at(2, n.y() / 2, n.z() / 2), kLevel);
  EXPECT_LT(solid.at(n.x() / 2, n.y() - 3, n.z() / 2), kLevel);
}

TEST(VisualHull, CarvingIsTighterThanTheFillAlongOneDirection) {
  const DensityGrid grid = ballGrid();
  MeshExtractionConfig config;
  config.surface = SurfaceDefinition::kDensity;
  config.threshold = kLevel;
  const double ball = isolateObject(grid, config).volume;
  config.solid.behind = Eigen::Vector3d::UnitX();
  const double behind = isolateObject(grid, config).volume;
  config.solid.behind = Eigen::Vector3d::Zero();
  config.solid.cameras = frontCameras();
  const MeshExtractionResult carved = isolateObject(grid, config);
  EXPECT_TRUE(carved.closed);
  EXPECT_EQ(carved.topology.genus, 0);
  // The shadow every camera agrees on tapers behind the ball (measured: 0.0065 on the ball's
  // 0.113); the one-direction fill is a cylinder of the ball's radius back to the box's face
  // (0.047 more).
  EXPECT_GT(carved.volume, ball + 0.004);
  EXPECT_LT(carved.volume, ball + 0.012);
  EXPECT_GT(behind, ball + 0.04);
}

TEST(VisualHull, BallSeenFromAllSidesIsUnchanged) {
  const DensityGrid grid = ballGrid();
  std::vector<ViewCamera> views;
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {1.0, -1.0}) views.push_back(cameraFrom(sign * Eigen::Vector3d::Unit(axis)));
  std::vector<char> ball(grid.values.size());
  for (std::size_t id = 0; id < ball.size(); ++id) ball[id] = grid.values[id] > kLevel;
  CarvingReport report;
  const std::vector<char> unseen = unseenByCameras(grid, ball, views, 1, &report);
  EXPECT_EQ(report.hidden, 0u);
  EXPECT_EQ(report.unseen, 0u);
  EXPECT_GT(report.seen_empty, 0u);
  for (std::size_t id = 0; id < unseen.size(); ++id) ASSERT_FALSE(unseen[id]) << id;
}

TEST(VisualHull, NodesOutsideEveryImageCountAsUnseen) {
  const DensityGrid grid = ballGrid();
  std::vector<char> ball(grid.values.size());
  for (std::size_t id = 0; id < ball.size(); ++id) ball[id] = grid.values[id] > kLevel;
  ViewCamera narrow = cameraFrom(Eigen::Vector3d::UnitX());
  narrow.camera.fx = narrow.camera.fy = 1000.0;  // 11 degrees: sees a disc of radius ~0.25 only
  CarvingReport report;
  const std::vector<char> unseen = unseenByCameras(grid, ball, {narrow}, 1, &report);
  EXPECT_GT(report.unseen, 0u);
  const Eigen::Vector3i corner(grid.dims.x() - 2, grid.dims.y() - 2, grid.dims.z() - 2);  // out of the image
  EXPECT_TRUE(unseen[grid.index(corner.x(), corner.y(), corner.z())]);
  EXPECT_FALSE(unseen[grid.index(grid.dims.x() - 2, grid.dims.y() / 2, grid.dims.z() / 2)]);  // in front
  EXPECT_THROW(unseenByCameras(grid, ball, {}), core::Error);
  ViewCamera broken = narrow;
  broken.camera.fx = -1.0;
  EXPECT_THROW(unseenByCameras(grid, ball, {broken}), core::Error);
  EXPECT_THROW(unseenByCameras(grid, ball, {narrow}, 0), core::Error);
}

TEST(VisualHull, AskingForMoreViewsCarvesLess) {
  const DensityGrid grid = ballGrid();
  std::vector<char> ball(grid.values.size());
  for (std::size_t id = 0; id < ball.size(); ++id) ball[id] = grid.values[id] > kLevel;
  const std::vector<ViewCamera> views = frontCameras();
  CarvingReport one, two, all;
  const std::vector<char> by_one = unseenByCameras(grid, ball, views, 1, &one);
  const std::vector<char> by_two = unseenByCameras(grid, ball, views, 2, &two);
  unseenByCameras(grid, ball, views, 6, &all);  // more than there are cameras: nothing is carved
  for (std::size_t id = 0; id < ball.size(); ++id)
    if (by_one[id]) ASSERT_TRUE(by_two[id]) << id;
  EXPECT_GT(two.hidden, one.hidden);  // beside the ball, only the tilted camera on that side looks
  EXPECT_EQ(all.seen_empty, 0u);
  EXPECT_EQ(all.hidden + all.unseen, one.seen_empty + one.hidden + one.unseen);
}

}  // namespace
}  // namespace demnerf::geometry
