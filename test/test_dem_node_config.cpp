// dem_node's parameters without a master (ParameterMap): its defaults are the library's, which
// `demnerf simulate` starts from too; ~dem_method, ~solver_config and the namespaces ~dem, ~fem,
// ~pinn, ~voxel, ~control apply as the CLI's --method, --config and a config file do.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "cli/simulate_settings.hpp"
#include "nodes/dem/dem_node_config.hpp"

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

/// A namespace as the parameter server hands it over: a struct of keys.
XmlRpc::XmlRpcValue keys(std::initializer_list<std::pair<const char*, XmlRpc::XmlRpcValue>> items) {
  XmlRpc::XmlRpcValue value;
  for (const auto& [key, item] : items) value[key] = item;
  return value;
}

std::string temporaryFile(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name + "_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << text;
  return path;
}

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
  const std::vector<std::pair<std::vector<std::string>, ParameterMap>> pairs{
      {{"--grid-spacings", "2.5"}, ParameterMap{{"dem_grid_spacings", 2.5}}},
      {{"--method", "mlp"}, ParameterMap{{"dem_method", "mlp"}}},
      {{"--method", "mlp", "--load-range", "0,1.5"},
       ParameterMap{{"dem_method", "mlp"},
                    {"dem", keys({{"parametric", keys({{"enabled", true}, {"load_range_min", 0.0},
                                                       {"load_range_max", 1.5}})}})}}},
      {{"--order", "1", "--threads", "2", "--time-limit", "9"},
       ParameterMap{{"fem_order", 1}, {"threads", 2}, {"solve_time_limit", 9.0}}},
  };
  for (const auto& [flags, parameters] : pairs) {
    const dm::SimulateOptions cli = cliSettings(flags);
    EXPECT_EQ(dm::solverConfigYaml(cli), dm::solverConfigYaml(DemNodeConfig::fromParameters(parameters).simulateOptions()))
        << flags.front() << " " << flags[1];
  }
}

TEST(DemNodeConfig, NamespacesAreTheSolverConfigFilesSections) {
  // The same settings as `demnerf simulate --config FILE` and as dem_node's namespaces.
  const std::string path = temporaryFile("dem_node_sections",
                                         "dem: {grid: {cell: 0.02}, adam: {iterations: 20}, network: {width: 16}}\n"
                                         "fem: {linear_solver: cg}\nvoxel: {order: 1}\ncontrol: {time_limit: 9}\n");
  const ParameterMap parameters{
      {"dem", keys({{"grid", keys({{"cell", 0.02}})}, {"adam", keys({{"iterations", 20}})},
                    {"network", keys({{"width", 16}})}})},
      {"fem", keys({{"linear_solver", "cg"}})},
      {"voxel", keys({{"order", 1}})},
      {"control", keys({{"time_limit", 9}})}};  // an int where a double is asked for, as ROS allows
  const dm::SimulateOptions node = DemNodeConfig::fromParameters(parameters).simulateOptions();
  EXPECT_EQ(dm::solverConfigYaml(cliSettings({"--config", path})), dm::solverConfigYaml(node));
  EXPECT_EQ(node.dem.grid.cell, 0.02);
  EXPECT_EQ(node.dem.adam.iterations, 20);
  EXPECT_EQ(node.voxel.order, 1);
  EXPECT_EQ(node.control.time_limit, 9.0);
  std::remove(path.c_str());
}

TEST(DemNodeConfig, ParametersOverrideTheSolverConfigFile) {
  const std::string path = temporaryFile("dem_node_solvers",
                                         "dem: {grid_spacings: 3, width: 16, depth: 3}\nvoxel: {order: 1}\n"
                                         "control: {time_limit: 10}\n");
  const DemNodeConfig config = DemNodeConfig::fromParameters(ParameterMap{{"solver_config", path},
                                                                           {"dem", keys({{"network", keys({{"depth", 4}})}})},
                                                                           {"dem_grid_spacings", 2.5},
                                                                           {"solve_time_limit", 20},
                                                                           {"threads", 1}});
  const dm::SimulateOptions o = config.simulateOptions();
  EXPECT_EQ(o.dem.grid.spacings, 2.5);  // live startup value over file
  EXPECT_EQ(o.dem.network.depth, 4);    // namespace over file
  EXPECT_EQ(o.dem.network.width, 16);   // file over default
  EXPECT_EQ(o.voxel.order, 1);
  EXPECT_EQ(o.control.time_limit, 20.0);
  EXPECT_EQ(o.dem.threads, 1);
  EXPECT_EQ(o.pinn.threads, 1);
  std::remove(path.c_str());
}

TEST(DemNodeConfig, MethodAndParametricModeUseTheLibrarysPresets) {
  const dm::SimulateOptions mlp = DemNodeConfig::fromParameters(ParameterMap{{"dem_method", "mlp"}}).simulateOptions();
  EXPECT_EQ(dm::solverConfigYaml(mlp), dm::solverConfigYaml(dm::solverDefaults("mlp")));
  EXPECT_EQ(mlp.dem.lbfgs.iterations, dm::paperDemConfig().lbfgs.iterations);

  const dm::DemConfig parametric =
      DemNodeConfig::fromParameters(
          ParameterMap{{"dem", keys({{"parametric", keys({{"enabled", true}, {"load_range_max", 1.5}})}})}})
          .simulateOptions()
          .dem;
  EXPECT_TRUE(parametric.parametric.enabled);
  EXPECT_EQ(parametric.grid.spacings, 0.0);
  EXPECT_EQ(parametric.adam.iterations, dm::kParametricAdamIterations);
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
  // A namespace's bad key or value is named with its section, as in a config file.
  EXPECT_NE(message(ParameterMap{{"dem", keys({{"grid", keys({{"cell", -1.0}})}})}}).find("dem.grid.cell"),
            std::string::npos);
  EXPECT_NE(message(ParameterMap{{"fem", keys({{"linear_solvr", "cg"}})}}).find("unknown key 'fem.linear_solvr'"),
            std::string::npos);
  // Parameters that moved into a namespace are refused with their new name, never ignored.
  EXPECT_NE(message(ParameterMap{{"dem_grid_cell", 0.02}}).find("~dem/grid/cell"), std::string::npos);
  EXPECT_NE(message(ParameterMap{{"parametric", true}}).find("~dem/parametric/enabled"), std::string::npos);
}
