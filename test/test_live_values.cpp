// dem_node's live settings as values (no ROS): a valid change is taken and says what changed, an
// invalid one names the value and leaves the settings as they were, and the material and load
// scale enter a solve's scenario.

#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "nodes/dem/live_values.hpp"

namespace {

namespace dm = demnerf::mechanics;
using dem_nerf::LiveSolveSettings;
using dem_nerf::LiveValues;

LiveSolveSettings start() {
  demnerf::core::Material material;
  material.youngs_modulus = 2e5;
  material.poisson_ratio = 0.25;
  return dem_nerf::initialLiveSettings(dm::SolverChoice::kDem, dm::SimulateOptions{}, material);
}

TEST(LiveValues, StartFromTheScenarioMaterialAndTheNodesOptions) {
  const LiveValues values = dem_nerf::liveValuesOf(start());
  EXPECT_EQ(values.youngs_modulus, 2e5);
  EXPECT_EQ(values.poisson_ratio, 0.25);
  EXPECT_EQ(values.solver, "dem");
  EXPECT_EQ(values.dem_grid_spacings, dm::DemConfig{}.grid.spacings);
  EXPECT_EQ(values.fem_order, dm::VoxelMeshConfig{}.order);
  EXPECT_EQ(values.solve_time_limit, dm::SolveControl{}.time_limit);
  EXPECT_EQ(values.load_scale, 1.0);
}

TEST(LiveValues, AValidChangeIsTakenAndANewMaterialNeedsANewModel) {
  const LiveSolveSettings before = start();
  LiveValues values = dem_nerf::liveValuesOf(before);
  values.load_scale = 2.0;
  values.solver = "fem";
  values.solve_time_limit = 5.0;
  const LiveSolveSettings scaled = dem_nerf::withLiveValues(before, values);
  EXPECT_EQ(scaled.solver, dm::SolverChoice::kFem);
  EXPECT_EQ(scaled.options.control.time_limit, 5.0);
  EXPECT_EQ(scaled.model_generation, before.model_generation) << "a load scale keeps the trained DEM";
  EXPECT_EQ(dem_nerf::describeChange(dem_nerf::liveValuesOf(before), values),
            "solver dem -> fem, solve_time_limit 60 -> 5, load_scale 1 -> 2");
  values.youngs_modulus = 1e5;
  values.dem_grid_spacings = 3.0;
  const LiveSolveSettings softer = dem_nerf::withLiveValues(scaled, values);
  EXPECT_EQ(softer.youngs_modulus, 1e5);
  EXPECT_EQ(softer.options.dem.grid.spacings, 3.0);
  EXPECT_GT(softer.model_generation, scaled.model_generation);
}

TEST(LiveValues, InvalidValuesAreRefusedByName) {
  const LiveSolveSettings before = start();
  const auto refused = [&](auto change, const std::string& name) {
    LiveValues values = dem_nerf::liveValuesOf(before);
    change(values);
    try {
      dem_nerf::withLiveValues(before, values);
      ADD_FAILURE() << name << " was taken";
    } catch (const demnerf::core::Error& error) {
      EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
    }
  };
  refused([](LiveValues& v) { v.poisson_ratio = 0.5; }, "poisson_ratio");
  refused([](LiveValues& v) { v.youngs_modulus = 0.0; }, "youngs_modulus");
  refused([](LiveValues& v) { v.load_scale = std::nan(""); }, "load_scale");
  refused([](LiveValues& v) { v.solver = "abaqus"; }, "abaqus");
  refused([](LiveValues& v) { v.fem_order = 3; }, "fem_order");
  refused([](LiveValues& v) { v.solve_time_limit = -1.0; }, "solve_time_limit");
  LiveSolveSettings parametric = before;
  parametric.options.dem.parametric.enabled = true;
  LiveValues values = dem_nerf::liveValuesOf(parametric);
  values.dem_grid_spacings += 1.0;
  EXPECT_THROW(dem_nerf::withLiveValues(parametric, values), demnerf::core::Error);
}

TEST(LiveValues, MaterialAndLoadScaleEnterTheScenario) {
  LiveSolveSettings settings = start();
  settings.load_scale = -2.0;
  demnerf::core::Scenario scenario;
  demnerf::core::Load load;
  load.force = Eigen::Vector3d(0, 0, -1);
  load.torque = Eigen::Vector3d(0.5, 0, 0);
  scenario.loads.push_back(load);
  scenario.body_force = Eigen::Vector3d(0, 0, -9.8);
  demnerf::core::Scenario as_given = scenario;
  settings.applyTo(as_given, /*scale_loads=*/false);
  EXPECT_EQ(as_given.material.youngs_modulus, 2e5);
  EXPECT_EQ(as_given.loads[0].force, load.force) << "a ~solve request's load is taken as given";
  settings.applyTo(scenario, /*scale_loads=*/true);
  EXPECT_EQ(scenario.material.poisson_ratio, 0.25);
  EXPECT_EQ(scenario.loads[0].force, Eigen::Vector3d(0, 0, 2));
  EXPECT_EQ(scenario.loads[0].torque, Eigen::Vector3d(-1, 0, 0));
  EXPECT_EQ(scenario.body_force, Eigen::Vector3d(0, 0, 19.6));
}

}  // namespace
