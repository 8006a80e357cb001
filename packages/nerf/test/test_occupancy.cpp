// Cascaded occupancy grids (nested grids for unbounded scenes), marching through them, and the
// cells no camera sees kept empty.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/occupancy_grid.hpp"
#include "demnerf/nerf/ray_marcher.hpp"

namespace demnerf::nerf {
namespace {

constexpr float kRadius = 0.3f;

/// A solid ball at the origin: density 200 / m inside, none outside.
class BallField : public Field {
 public:
  explicit BallField(const Box& box, float radius = kRadius) : box_(box), radius_(radius) {}
  Box bounds() const override { return box_; }
  void density(const float* p, std::int64_t n, float* sigma) const override {
    for (std::int64_t i = 0; i < n; ++i) {
      const float r2 = p[3 * i] * p[3 * i] + p[3 * i + 1] * p[3 * i + 1] + p[3 * i + 2] * p[3 * i + 2];
      sigma[i] = r2 < radius_ * radius_ ? 200.0f : 0.0f;
    }
  }
  void query(const float* p, const float*, std::int64_t n, float* sigma, float* rgb) const override {
    density(p, n, sigma);
    for (std::int64_t i = 0; i < 3 * n; ++i) rgb[i] = 0.5f;
  }

 private:
  Box box_;
  float radius_;
};

Box cube(float half) {
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = -half;
    box.max[a] = half;
  }
  return box;
}

OccupancyConfig smallGrid() {
  OccupancyConfig config;
  config.resolution = 32;
  return config;
}

/// Samples a ray takes through the grid, all of them.
std::vector<float> march(const MarchParams& params, const OccupancyGrid& grid, const float* origin,
                         const float* direction, std::vector<float>* steps = nullptr) {
  RayCursor cursor;
  startRay(params, grid.bounds(), origin, direction, 0.5f, cursor);
  std::vector<float> t;
  float positions[3 * 64], ts[64], dts[64];
  while (!cursor.done) {
    const int got = marchRay(params, grid, cursor, 64, positions, ts, dts);
    t.insert(t.end(), ts, ts + got);
    if (steps) steps->insert(steps->end(), dts, dts + got);
  }
  return t;
}

}  // namespace

TEST(Occupancy, CascadeCountFollowsTheSceneExtent) {
  OccupancyConfig config;
  EXPECT_EQ(cascadeCount(config, 4.0), 1);  // the default: one grid
  config.cascades = 0;
  EXPECT_EQ(cascadeCount(config, 1.0), 1);
  EXPECT_EQ(cascadeCount(config, 2.0), 2);
  EXPECT_EQ(cascadeCount(config, 4.0), 3);
  EXPECT_EQ(cascadeCount(config, 16.0), 5);
  EXPECT_EQ(cascadeCount(config, 3.0), 3);  // rounded up: the outer box must hold the scene
  config.cascades = 2;
  EXPECT_EQ(cascadeCount(config, 16.0), 2);
}

TEST(Occupancy, PointsFallInTheSmallestCascadeThatHoldsThem) {
  const OccupancyGrid grid(smallGrid(), cube(4.0f), 0.01f, 3);
  EXPECT_EQ(grid.cells(), 3 * 32 * 32 * 32);
  const float centre[3] = {0.1f, -0.2f, 0.3f}, middle[3] = {1.5f, 0.0f, 0.0f}, outer[3] = {0.0f, -3.0f, 0.0f},
              outside[3] = {0.0f, 0.0f, 4.5f};
  EXPECT_EQ(grid.cascadeOf(centre), 0);
  EXPECT_EQ(grid.cascadeOf(middle), 1);
  EXPECT_EQ(grid.cascadeOf(outer), 2);
  EXPECT_EQ(grid.cascadeOf(outside), -1);
  EXPECT_EQ(grid.cellOf(outside), -1);
  EXPECT_FLOAT_EQ(grid.cellSize(0), 2.0f / 32);
  EXPECT_FLOAT_EQ(grid.cellSize(2), 8.0f / 32);
  EXPECT_LT(grid.cellOf(centre), grid.cellsPerCascade());
  EXPECT_GE(grid.cellOf(outer), 2 * grid.cellsPerCascade());
  // Every cell is occupied at first, covered cells (an inner cascade holds them) excepted: of
  // cascades 1 and 2 the central eighth is covered.
  std::int64_t occupied = 0;
  for (std::int64_t c = 0; c < grid.cells(); ++c) occupied += grid.occupied(c);
  EXPECT_EQ(occupied, grid.cellsPerCascade() + 2 * (grid.cellsPerCascade() * 7 / 8));
  EXPECT_DOUBLE_EQ(grid.occupiedFraction(), 1.0);
}

TEST(Occupancy, CascadesMarchOnlyNearTheBallAndStepsGrowOutwards) {
  const Box box = cube(4.0f);
  const BallField ball(box);
  MarchConfig mc;
  mc.cone_angle = 1.0 / 64;
  const MarchParams params = MarchParams::make(mc, box, 4.0, 32);
  OccupancyGrid cascaded(smallGrid(), box, params.min_step, 3);
  cascaded.rebuild(ball, 8, 3);
  EXPECT_LT(cascaded.occupiedFraction(), 0.03);
  const float origin[3] = {-3.9f, 0.01f, 0.02f}, along_x[3] = {1.0f, 0.0f, 0.0f};
  const std::vector<float> near = march(params, cascaded, origin, along_x);
  ASSERT_FALSE(near.empty());
  // Samples stay within a cell (of the innermost cascade) of the ball and cover its chord.
  const float slack = std::sqrt(3.0f) * cascaded.cellSize(0) + params.min_step;
  for (float t : near) EXPECT_LT(std::fabs(origin[0] + t), kRadius + slack) << t;
  const float step = near.size() > 1 ? near[1] - near[0] : 0.0f;
  EXPECT_LT(origin[0] + near.front(), -kRadius + cascaded.cellSize(0) + step);
  EXPECT_GT(origin[0] + near.back(), kRadius - cascaded.cellSize(0) - step);

  // With every cell occupied, steps grow with distance and are largest in the outer cascade.
  OccupancyGrid full(smallGrid(), box, params.min_step, 3);
  const float corner[3] = {-3.9f, -3.9f, -3.9f};
  const float diagonal[3] = {1.0f / std::sqrt(3.0f), 1.0f / std::sqrt(3.0f), 1.0f / std::sqrt(3.0f)};
  std::vector<float> steps;
  const std::vector<float> t = march(params, full, corner, diagonal, &steps);
  ASSERT_GT(steps.size(), 10u);
  float largest = 0.0f;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    EXPECT_LE(steps[i], full.cellSize(2) * 1.0001f);
    // Growing while in the outer cascade on the way in (t < 3.29 there).
    if (i > 0 && t[i] < 3.2f) EXPECT_GE(steps[i], steps[i - 1] * 0.9999f);
    largest = std::max(largest, steps[i]);
  }
  EXPECT_GT(largest, 2.0f * steps.front());
  // A step that starts in the innermost cascade is at most one of its cells.
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const float s = t[i] - 0.5f * steps[i];
    const float p[3] = {corner[0] + s * diagonal[0], corner[1] + s * diagonal[1], corner[2] + s * diagonal[2]};
    if (full.cascadeOf(p) == 0) EXPECT_LE(steps[i], full.cellSize(0) * 1.0001f + 1e-6f);
  }
}

TEST(Occupancy, CellsNoCameraSeesStayEmpty) {
  OccupancyConfig config = smallGrid();
  config.cull_unseen = true;
  OccupancyGrid grid(config, cube(4.0f), 0.01f, 3);
  // One camera at -x looking along +x (optical z), a narrow 20 x 20 px view.
  GridCamera camera{};
  const float rotation[9] = {0, 0, 1, 0, 1, 0, -1, 0, 0};  // columns: x_cam = -z, y_cam = y, z_cam = +x
  std::copy(rotation, rotation + 9, camera.rotation);
  camera.origin[0] = -3.0f;
  camera.fx = camera.fy = 100.0f;
  camera.cx = camera.cy = 10.0f;
  camera.width = camera.height = 20;
  grid.setVisibility({camera});
  const float ahead[3] = {0.0f, 0.0f, 0.0f}, behind[3] = {-3.8f, 0.0f, 0.0f}, aside[3] = {0.0f, 2.5f, 0.0f};
  EXPECT_TRUE(grid.occupied(grid.cellOf(ahead)));
  EXPECT_FALSE(grid.occupied(grid.cellOf(behind)));
  EXPECT_FALSE(grid.occupied(grid.cellOf(aside)));
  std::int64_t occupied = 0;
  for (std::int64_t c = 0; c < grid.cells(); ++c) occupied += grid.occupied(c);
  EXPECT_LT(occupied, grid.cells() / 5);
  // Updates never bring an unseen cell back.
  const BallField everywhere(cube(4.0f), 100.0f);
  grid.rebuild(everywhere, 1, 1);
  EXPECT_FALSE(grid.occupied(grid.cellOf(behind)));
  // Without cameras every cell counts as seen again, and a newly seen cell starts occupied.
  grid.setVisibility({});
  EXPECT_TRUE(grid.occupied(grid.cellOf(aside)));
}

TEST(Occupancy, CascadedModelsRoundTripAndOldFilesHoldOneGrid) {
  NerfConfig config;
  config.occupancy.cascades = 0;  // from aabb_scale
  config.occupancy.resolution = 16;
  config.hash.log2_table_size = 10;
  const NerfModel model(config, cube(6.0f), 4.0);
  EXPECT_EQ(model.grid().cascades(), 3);
  const std::string path = (std::filesystem::temp_directory_path() / "demnerf_cascades.nerf").string();
  saveModel(model, path);
  const NerfModel loaded = loadModel(path);
  EXPECT_EQ(loaded.grid().cascades(), 3);
  EXPECT_EQ(loaded.grid().bits(), model.grid().bits());
  nlohmann::json old = toJson(config);
  old["occupancy"].erase("cascades");
  EXPECT_EQ(nerfConfigFromJson(old).occupancy.cascades, 1);
  EXPECT_EQ(nerfConfigFromJson(toJson(config)).occupancy.cascades, 0);
}

}  // namespace demnerf::nerf
