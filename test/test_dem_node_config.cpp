// dem_node's parameters without a master (ParameterMap): its defaults are the library's, which
// `demnerf simulate` starts from too, and ~solver_config, the method and the parameters apply in
// the same order as the CLI's preset, --config and flags.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "cli/simulate_settings.hpp"
#include "nodes/dem/dem_node_config.hpp"
#include "nodes/nerf/nerf_node_config.hpp"
#include "pipeline/surface_defaults.hpp"

namespace dm = demnerf::mechanics;
using dem_nerf::DemNodeConfig;
using dem_nerf::ParameterMap;

TEST(DemNodeConfig, DefaultsAreTheLibrarysAsForTheCli) {
  const DemNodeConfig config = DemNodeConfig::fromParameters(ParameterMap{});
  // Every solver setting, compared as the YAML that lists them all.
  EXPECT_EQ(dm::solverConfigYaml(config.simulateOptions()), dm::solverConfigYaml(dm::solverDefaults()));
  EXPECT_EQ(config.simulateOptions().dem.grid.spacings, dm::DemConfig{}.grid.spacings);
  EXPECT_EQ(config.simulateOptions().voxel.order, dm::VoxelMeshConfig{}.order);
  EXPECT_EQ(config.simulateOptions().control.time_limit, dm::SolveControl{}.time_limit);
  EXPECT_EQ(config.solver, "dem");
}

namespace {

/// `demnerf simulate`'s settings for these flags (no --particles etc.: only the solver settings).
dm::SimulateOptions cliSettings(const std::vector<std::string>& flags) {
  return demnerf::cli::simulateSettings(demnerf::cli::Arguments(flags, {"newton", "quiet", "json", "print-config"}));
}

}  // namespace

TEST(DemNodeConfig, TheCliAndTheNodeGiveTheSameSettingsForTheSameChoice) {
  // No flags and no parameters: both are the library's defaults.
  EXPECT_EQ(dm::solverConfigYaml(cliSettings({})),
            dm::solverConfigYaml(DemNodeConfig::fromParameters(ParameterMap{}).simulateOptions()));
  // The same choices spelled as flags and as parameters go through the same rules.
  XmlRpc::XmlRpcValue range;
  range[0] = 0.0;
  range[1] = 1.5;
  const std::vector<std::pair<std::vector<std::string>, ParameterMap>> pairs{
      {{"--grid-spacings", "2.5"}, ParameterMap{{"dem_grid_spacings", 2.5}}},
      {{"--grid-body-cells", "300"}, ParameterMap{{"dem_grid_body_cells", 300.0}}},
      {{"--method", "mlp", "--grid-cell", "0.02"}, ParameterMap{{"dem_method", "mlp"}, {"dem_grid_cell", 0.02}}},
      {{"--method", "mlp", "--load-range", "0,1.5"},
       ParameterMap{{"dem_method", "mlp"}, {"parametric", true}, {"load_range", range}}},
      {{"--order", "1", "--threads", "2", "--time-limit", "9"},
       ParameterMap{{"fem_order", 1}, {"threads", 2}, {"solve_time_limit", 9.0}}},
  };
  for (const auto& [flags, parameters] : pairs) {
    const dm::SimulateOptions cli = cliSettings(flags);
    EXPECT_EQ(dm::solverConfigYaml(cli), dm::solverConfigYaml(DemNodeConfig::fromParameters(parameters).simulateOptions()))
        << flags.front() << " " << flags[1];
  }
  // A grid chosen over the MLP preset means no Adam unless asked (normalised()), in both.
  EXPECT_EQ(cliSettings({"--method", "mlp", "--grid-cell", "0.02"}).dem.adam.iterations, 0);
  const dm::DemConfig asked = DemNodeConfig::fromParameters(ParameterMap{{"dem_grid_cell", 0.02}, {"dem_iterations", 20}})
                                  .simulateOptions()
                                  .dem;
  EXPECT_EQ(cliSettings({"--grid-cell", "0.02", "--iterations", "20"}).dem.adam.iterations, asked.adam.iterations);
  EXPECT_EQ(asked.adam.iterations, 20);
}

TEST(DemNodeConfig, NerfNodeExtractsTheSurfaceTheCliExtracts) {
  // NerfNodeConfig's defaults without parameters are the struct's; the CLI's extract and sample
  // read the same dem_nerf::SurfaceDefaults.
  const dem_nerf::NerfNodeConfig nerf;
  EXPECT_EQ(nerf.extract_resolution, dem_nerf::SurfaceDefaults{}.resolution);
  EXPECT_EQ(nerf.surface_opacity, dem_nerf::SurfaceDefaults{}.opacity);
}

TEST(DemNodeConfig, ParametersOverrideTheSolverConfigFile) {
  const std::string path = ::testing::TempDir() + "dem_node_solvers_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "dem: {grid_spacings: 3, width: 16}\nvoxel: {order: 1}\ncontrol: {time_limit: 10}\n";
  const DemNodeConfig config = DemNodeConfig::fromParameters(ParameterMap{{"solver_config", path},
                                                                           {"dem_grid_spacings", 2.5},
                                                                           {"solve_time_limit", 20},
                                                                           {"threads", 1}});
  const dm::SimulateOptions o = config.simulateOptions();
  EXPECT_EQ(o.dem.grid.spacings, 2.5);  // parameter over file
  EXPECT_EQ(o.dem.network.width, 16);           // file over default
  EXPECT_EQ(o.voxel.order, 1);
  EXPECT_EQ(o.control.time_limit, 20.0);
  EXPECT_EQ(o.dem.threads, 1);
  EXPECT_EQ(o.pinn.threads, 1);
  std::remove(path.c_str());
}

TEST(DemNodeConfig, MethodAndParametricModeUseTheLibrarysPresets) {
  const dm::SimulateOptions mlp = DemNodeConfig::fromParameters(ParameterMap{{"dem_method", "mlp"}}).simulateOptions();
  EXPECT_EQ(dm::solverConfigYaml(mlp), dm::solverConfigYaml(dm::solverDefaults("mlp")));
  EXPECT_EQ(mlp.dem.boundary.kind, dm::DemConfig::Boundary::kPenalty);

  XmlRpc::XmlRpcValue range;
  range[0] = 0.0;
  range[1] = 1.5;
  const dm::DemConfig parametric =
      DemNodeConfig::fromParameters(ParameterMap{{"parametric", true}, {"load_range", range}}).simulateOptions().dem;
  EXPECT_TRUE(parametric.parametric.enabled);
  EXPECT_EQ(parametric.grid.spacings, 0.0);
  EXPECT_EQ(parametric.adam.iterations, dm::paperDemConfig().adam.iterations);
  EXPECT_EQ(parametric.parametric.load_range_max, 1.5);
}

TEST(DemNodeConfig, BadParametersAreRejectedByName) {
  auto message = [](ParameterMap parameters) -> std::string {
    try {
      DemNodeConfig::fromParameters(parameters);
    } catch (const demnerf::core::Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message(ParameterMap{{"dem_method", "grids"}}).find("~dem_method"), std::string::npos);
  EXPECT_NE(message(ParameterMap{{"dem_grid_spacings", -1.0}}).find("~dem_grid_spacings"), std::string::npos);
  EXPECT_NE(message(ParameterMap{{"solve_time_limit", -1.0}}).find("~solve_time_limit"), std::string::npos);
  EXPECT_NE(message(ParameterMap{{"solver_config", "/nonexistent/solvers.yaml"}}).find("/nonexistent/solvers.yaml"),
            std::string::npos);
  XmlRpc::XmlRpcValue range;
  range[0] = 1.2;
  range[1] = 1.5;
  EXPECT_NE(message(ParameterMap{{"parametric", true}, {"load_range", range}}).find("~load_range"), std::string::npos);
}
