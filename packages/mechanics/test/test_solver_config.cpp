// The solver configuration file (solver_config_yaml.hpp): the shipped example, overrides, the DEM
// presets, and the messages for bad files.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;

namespace {

const std::string kShipped = std::string(DEMNERF_SOURCE_DIR) + "/config/solvers.yaml";

/// The message of the core::Error that parsing `text` throws ("" when it does not throw).
std::string errorOf(const std::string& text) {
  try {
    dm::parseSolverConfig(text, "bad.yaml");
  } catch (const core::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SolverConfig, ShippedExampleListsEveryKeyAtItsDefault) {
  const dm::SimulateOptions loaded = dm::loadSolverConfig(kShipped);
  EXPECT_EQ(dm::solverConfigYaml(loaded), dm::solverConfigYaml(dm::SimulateOptions{}))
      << "config/solvers.yaml is not at the defaults: regenerate it with `demnerf simulate --print-config`";
  const YAML::Node root = YAML::LoadFile(kShipped);
  for (const std::string& key : dm::solverConfigKeys()) {
    const auto dot = key.find('.');
    const YAML::Node node = dot == std::string::npos ? root[key] : root[key.substr(0, dot)][key.substr(dot + 1)];
    EXPECT_TRUE(node.IsDefined() && node.IsScalar()) << "config/solvers.yaml lacks " << key;
  }
}

TEST(SolverConfig, WrittenSettingsReadBackTheSame) {
  dm::SimulateOptions options;
  options.dem = dm::paperDemConfig();
  options.dem.jitter_band = 2.5;
  options.dem.tolerance = 3e-11;
  options.dem.seed = -7;
  options.fem.linear_solver = dm::FemConfig::LinearSolver::kConjugateGradient;
  options.fem.ordering = dm::FemConfig::Ordering::kNestedDissection;
  options.pinn.activation = "sin";
  options.pinn.verbose = true;
  options.voxel = {0.0125, 1};
  options.mesher = dm::SimulateOptions::Mesher::kVoxel;
  options.control.time_limit = 0.0;
  const std::string text = dm::solverConfigYaml(options);
  const dm::SimulateOptions back = dm::parseSolverConfig(text, "written");
  EXPECT_EQ(dm::solverConfigYaml(back), text);
  EXPECT_EQ(back.dem.boundary, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(back.dem.tolerance, 3e-11);
  EXPECT_EQ(back.dem.seed, -7);
  EXPECT_EQ(back.fem.linear_solver, dm::FemConfig::LinearSolver::kConjugateGradient);
  EXPECT_EQ(back.pinn.activation, "sin");
  EXPECT_EQ(back.voxel.cell, 0.0125);
  EXPECT_EQ(back.voxel.order, 1);
  EXPECT_EQ(back.mesher, dm::SimulateOptions::Mesher::kVoxel);
  EXPECT_EQ(back.control.time_limit, 0.0);
}

TEST(SolverConfig, AFileChangesOnlyTheKeysItNames) {
  dm::SimulateOptions base;
  base.dem.width = 17;  // not in the file: kept
  const dm::SimulateOptions o = dm::parseSolverConfig(
      "dem: {grid_spacings: 0, adam_iterations: 300, boundary: penalty}\n"
      "fem:\n  ordering: nested_dissection\n  threads: 2\n"
      "pinn:\n"
      "voxel: {order: 1}\nmesher: voxel\ncontrol: {time_limit: 5.5}\n",
      "partial", base);
  EXPECT_EQ(o.dem.width, 17);
  EXPECT_EQ(o.dem.grid_spacings, 0.0);
  EXPECT_EQ(o.dem.adam_iterations, 300);
  EXPECT_EQ(o.dem.boundary, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(o.dem.depth, dm::DemConfig{}.depth);
  EXPECT_EQ(o.fem.ordering, dm::FemConfig::Ordering::kNestedDissection);
  EXPECT_EQ(o.fem.threads, 2);
  EXPECT_EQ(o.fem.linear_solver, dm::FemConfig{}.linear_solver);
  EXPECT_EQ(o.voxel.order, 1);
  EXPECT_EQ(o.voxel.cell, 0.0);
  EXPECT_EQ(o.mesher, dm::SimulateOptions::Mesher::kVoxel);
  EXPECT_EQ(o.control.time_limit, 5.5);
  EXPECT_EQ(o.control.progress_interval, 1.0);
  // An empty file changes nothing.
  EXPECT_EQ(dm::solverConfigYaml(dm::parseSolverConfig("", "empty", base)), dm::solverConfigYaml(base));
}

TEST(SolverConfig, BadFilesAreRejectedNamingTheFileAndTheKey) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {"dem: {widht: 8}", "bad.yaml: unknown key 'dem.widht'"},
      {"solver: {width: 8}", "bad.yaml: unknown key 'solver'"},
      {"dem: {width: 0}", "bad.yaml: 'dem.width' must be an integer >= 1, got 0"},
      {"dem: {width: eight}", "bad.yaml: 'dem.width' must be an integer >= 1, got 'eight'"},
      {"dem: {width: 1.5}", "'dem.width' must be an integer"},
      {"dem: {grid_degree: 4}", "'dem.grid_degree' must be an integer in [1, 3], got 4"},
      {"dem: {grid_surface_share: 1.5}", "'dem.grid_surface_share' must be a number in [0, 1]"},
      {"dem: {adam_learning_rate: 0}", "'dem.adam_learning_rate' must be a number > 0"},
      {"dem: {boundary: soft}", "'dem.boundary' must be one of exact, penalty, got 'soft'"},
      {"dem: {activation: relu}", "'dem.activation' must be one of tanh, sigmoid, softplus, sin"},
      {"dem: {jitter: maybe}", "'dem.jitter' must be true or false"},
      {"dem: {load_range_max: .inf}", "'dem.load_range_max' must be a number"},
      {"dem: {width: [1, 2]}", "'dem.width' must be an integer"},
      {"fem: {linear_solver: lu}", "'fem.linear_solver' must be one of ldlt, cg, got 'lu'"},
      {"pinn: {activation: sigmoid}", "'pinn.activation' must be one of tanh, sin, softplus"},
      {"voxel: {order: 3}", "'voxel.order' must be an integer in [1, 2], got 3"},
      {"mesher: tetgen", "'mesher' must be one of cgal, voxel, got 'tetgen'"},
      {"control: {time_limit: -1}", "'control.time_limit' must be a number >= 0, got -1"},
      {"dem: 3", "bad.yaml: section 'dem' must be a mapping"},
      {"[1, 2]", "bad.yaml: expected a mapping"},
      {"dem: {width: 8", "bad.yaml: not valid YAML"},
  };
  for (const Case& c : cases) {
    const std::string message = errorOf(c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos) << "'" << c.text << "' gave: '" << message << "'";
  }
  EXPECT_THROW(dm::loadSolverConfig("/nonexistent/solvers.yaml"), core::Error);
}

TEST(SolverConfig, TheDefaultDemIsTheFeatureGridAndThePaperDemTheMlp) {
  const dm::DemConfig grid = dm::demConfigForMethod("grid");
  EXPECT_EQ(dm::solverConfigYaml(dm::solverDefaults()), dm::solverConfigYaml(dm::SimulateOptions{}));
  EXPECT_EQ(grid.grid_body_cells, 600.0);
  EXPECT_EQ(grid.grid_quadrature, dm::DemConfig::GridQuadrature::kCells);
  EXPECT_GT(grid.grid_extension_fill, 0.0);
  EXPECT_EQ(grid.adam_iterations, 0);
  EXPECT_EQ(grid.boundary, dm::DemConfig::Boundary::kExact);
  const dm::DemConfig mlp = dm::demConfigForMethod("mlp");
  EXPECT_EQ(mlp.grid_spacings, 0.0);
  EXPECT_EQ(mlp.grid_body_cells, 0.0);
  EXPECT_EQ(mlp.grid_cell, 0.0);
  EXPECT_GT(mlp.adam_iterations, 0);
  EXPECT_EQ(mlp.boundary, dm::DemConfig::Boundary::kPenalty);
  EXPECT_THROW(dm::demConfigForMethod("grids"), core::Error);
  const dm::DemConfig parametric = dm::parametricDemConfig(grid);
  EXPECT_TRUE(parametric.parametric);
  EXPECT_EQ(parametric.grid_spacings, 0.0);
  EXPECT_EQ(parametric.grid_body_cells, 0.0);
  EXPECT_EQ(parametric.adam_iterations, mlp.adam_iterations);
  EXPECT_EQ(parametric.boundary, dm::DemConfig::Boundary::kExact);

  // Each preset is a configuration the solver accepts (the grid alone refuses parametric mode and
  // the penalty boundary).
  const core::ParticleCloud cloud =
      dm::makeBoxParticles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario scenario = dm::uniaxialTractionScenario(1e5);
  for (const dm::DemConfig& config : {grid, mlp, parametric}) EXPECT_NO_THROW(dm::DemSolver(cloud, scenario, config));
  dm::DemConfig broken = grid;
  broken.parametric = true;
  EXPECT_THROW(dm::DemSolver(cloud, scenario, broken), core::Error);

  // A file applies over the method's preset.
  const std::string path = ::testing::TempDir() + "solver_config_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "dem:\n  adam_iterations: 200\ncontrol:\n  time_limit: 0\n";
  const dm::SimulateOptions o = dm::solverDefaults("mlp", path);
  EXPECT_EQ(o.dem.adam_iterations, 200);
  EXPECT_EQ(o.dem.boundary, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(o.control.time_limit, 0.0);
  std::remove(path.c_str());
}
