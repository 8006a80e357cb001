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
    // "dem.grid.cell" is root["dem"]["grid"]["cell"].
    YAML::Node node = YAML::Clone(root);
    std::size_t begin = 0;
    while (node.IsDefined()) {
      const std::size_t dot = key.find('.', begin);
      node.reset(node[key.substr(begin, dot == std::string::npos ? std::string::npos : dot - begin)]);
      if (dot == std::string::npos) break;
      begin = dot + 1;
    }
    EXPECT_TRUE(node.IsDefined() && node.IsScalar()) << "config/solvers.yaml lacks " << key;
  }
}

TEST(SolverConfig, GaussNewtonFileTurnsTheMlpPresetIntoGaussNewtonSteps) {
  // `demnerf simulate --method mlp --config config/dem_mlp_gauss_newton.yaml`: the preset first,
  // the file over it, so the paper's network and exact boundary train by Gauss-Newton alone.
  const dm::SimulateOptions o =
      dm::solverDefaults("mlp", std::string(DEMNERF_SOURCE_DIR) + "/config/dem_mlp_gauss_newton.yaml");
  EXPECT_EQ(o.dem.lbfgs.iterations, 0);
  EXPECT_EQ(o.dem.gauss_newton.steps, 150);  // a cap: the steps stop once converged
  EXPECT_DOUBLE_EQ(o.dem.gauss_newton.tolerance, 2e-3);
  EXPECT_EQ(o.dem.gauss_newton.window, 10);
  EXPECT_DOUBLE_EQ(o.dem.gauss_newton.recheck_tolerance, 3e-4);  // a refused converged answer goes on
  EXPECT_EQ(dm::SimulateOptions{}.dem.gauss_newton.recheck_tolerance, 0.0);
  EXPECT_EQ(o.dem.gauss_newton.sample, 500);
  EXPECT_TRUE(o.dem.gauss_newton.spread);
  EXPECT_TRUE(o.dem.gauss_newton.current_tangent);
  EXPECT_EQ(o.dem.boundary.kind, dm::DemConfig::Boundary::kExact);
  EXPECT_GT(o.dem.lbfgs.cell_spacings, 0.0);  // Gauss-Newton needs the cell quadrature
  EXPECT_EQ(o.dem.lbfgs.cell_boundary_levels, 1);  // cut cells split once: the NeRF T-bar's twist
  EXPECT_EQ(dm::SimulateOptions{}.dem.lbfgs.cell_boundary_levels, 0);
  EXPECT_EQ(o.dem.grid.body_cells, 0.0);      // the MLP alone, no feature grid
  EXPECT_EQ(dm::SimulateOptions{}.dem.gauss_newton.steps, 0) << "Gauss-Newton is not the default";
}

TEST(SolverConfig, WrittenSettingsReadBackTheSame) {
  dm::SimulateOptions options;
  options.dem = dm::paperDemConfig();
  options.dem.boundary.kind = dm::DemConfig::Boundary::kPenalty;  // not a default
  options.dem.adam.jitter_band = 2.5;
  options.dem.lbfgs.tolerance = 3e-11;
  options.dem.lbfgs.cell_boundary_levels = 2;
  options.dem.gauss_newton.recheck_tolerance = 1e-4;
  options.dem.network.seed = -7;
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
  EXPECT_EQ(back.dem.boundary.kind, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(back.dem.lbfgs.tolerance, 3e-11);
  EXPECT_EQ(back.dem.lbfgs.cell_boundary_levels, 2);
  EXPECT_EQ(back.dem.gauss_newton.recheck_tolerance, 1e-4);
  EXPECT_EQ(back.dem.network.seed, -7);
  EXPECT_EQ(back.fem.linear_solver, dm::FemConfig::LinearSolver::kConjugateGradient);
  EXPECT_EQ(back.pinn.activation, "sin");
  EXPECT_EQ(back.voxel.cell, 0.0125);
  EXPECT_EQ(back.voxel.order, 1);
  EXPECT_EQ(back.mesher, dm::SimulateOptions::Mesher::kVoxel);
  EXPECT_EQ(back.control.time_limit, 0.0);
}

TEST(SolverConfig, AFileChangesOnlyTheKeysItNames) {
  dm::SimulateOptions base;
  base.dem.network.width = 17;  // not in the file: kept
  const dm::SimulateOptions o = dm::parseSolverConfig(
      "dem: {grid_spacings: 0, adam_iterations: 300, boundary: penalty}\n"
      "fem:\n  ordering: nested_dissection\n  threads: 2\n"
      "pinn:\n"
      "voxel: {order: 1}\nmesher: voxel\ncontrol: {time_limit: 5.5}\n",
      "partial", base);
  EXPECT_EQ(o.dem.network.width, 17);
  EXPECT_EQ(o.dem.grid.spacings, 0.0);
  EXPECT_EQ(o.dem.adam.iterations, 300);
  EXPECT_EQ(o.dem.boundary.kind, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(o.dem.network.depth, dm::DemConfig{}.network.depth);
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

TEST(SolverConfig, NestedKeysAndTheEarlierFlatKeysReadTheSame) {
  const dm::SimulateOptions nested = dm::parseSolverConfig(
      "dem:\n  load_steps: 3\n  grid: {cell: 0.02, quadrature: particles}\n  adam: {iterations: 40, jitter: false}\n"
      "  network: {width: 12}\n  boundary: {kind: penalty}\n  parametric: {samples: 7}\n",
      "nested");
  EXPECT_EQ(nested.dem.load_steps, 3);
  EXPECT_EQ(nested.dem.grid.cell, 0.02);
  EXPECT_EQ(nested.dem.grid.quadrature, dm::DemConfig::GridQuadrature::kParticles);
  EXPECT_EQ(nested.dem.adam.iterations, 40);
  EXPECT_FALSE(nested.dem.adam.jitter);
  EXPECT_EQ(nested.dem.network.width, 12);
  EXPECT_EQ(nested.dem.boundary.kind, dm::DemConfig::Boundary::kPenalty);
  EXPECT_EQ(nested.dem.parametric.samples, 7);
  // Files written before DemConfig had parts spell the same settings flat.
  const dm::SimulateOptions flat = dm::parseSolverConfig(
      "dem: {load_steps: 3, grid_cell: 0.02, grid_quadrature: particles, adam_iterations: 40, jitter: false,\n"
      "      width: 12, boundary: penalty, parametric_samples: 7}\n",
      "flat");
  EXPECT_EQ(dm::solverConfigYaml(flat), dm::solverConfigYaml(nested));
  EXPECT_NE(errorOf("dem: {grid: {cel: 1}}").find("unknown key 'dem.grid.cel'"), std::string::npos);
  EXPECT_NE(errorOf("dem: {grid: 3}").find("section 'dem.grid' must be a mapping"), std::string::npos);
}

TEST(SolverConfig, BadFilesAreRejectedNamingTheFileAndTheKey) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {"dem: {widht: 8}", "bad.yaml: unknown key 'dem.widht'"},
      {"solver: {width: 8}", "bad.yaml: unknown key 'solver'"},
      {"dem: {width: 0}", "bad.yaml: 'dem.network.width' must be an integer >= 1, got 0"},
      {"dem: {width: eight}", "bad.yaml: 'dem.network.width' must be an integer >= 1, got 'eight'"},
      {"dem: {width: 1.5}", "'dem.network.width' must be an integer"},
      {"dem: {grid_degree: 4}", "'dem.grid.degree' must be an integer in [1, 3], got 4"},
      {"dem: {grid_surface_share: 1.5}", "'dem.grid.surface_share' must be a number in [0, 1]"},
      {"dem: {adam_learning_rate: 0}", "'dem.adam.learning_rate' must be a number > 0"},
      {"dem: {boundary: soft}", "'dem.boundary.kind' must be one of exact, penalty, got 'soft'"},
      {"dem: {activation: relu}", "'dem.network.activation' must be one of tanh, sigmoid, softplus, sin"},
      {"dem: {jitter: maybe}", "'dem.adam.jitter' must be true or false"},
      {"dem: {load_range_max: .inf}", "'dem.parametric.load_range_max' must be a number"},
      {"dem: {width: [1, 2]}", "'dem.network.width' must be an integer"},
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
  EXPECT_EQ(grid.grid.body_cells, 2000.0);
  EXPECT_EQ(grid.grid.nested_levels, 1);  // the 10 mm T-bar grid started from a 20 mm one
  EXPECT_EQ(grid.grid.quadrature, dm::DemConfig::GridQuadrature::kCells);
  EXPECT_GT(grid.grid.extension_fill, 0.0);
  EXPECT_EQ(grid.adam.iterations, 0);
  EXPECT_EQ(grid.boundary.kind, dm::DemConfig::Boundary::kExact);
  const dm::DemConfig mlp = dm::demConfigForMethod("mlp");
  EXPECT_EQ(mlp.grid.spacings, 0.0);
  EXPECT_EQ(mlp.grid.body_cells, 0.0);
  EXPECT_EQ(mlp.grid.cell, 0.0);
  EXPECT_EQ(mlp.adam.iterations, 0);
  EXPECT_GT(mlp.lbfgs.iterations, 0);
  EXPECT_GT(mlp.lbfgs.sample_iterations, 0);
  EXPECT_EQ(mlp.boundary.kind, dm::DemConfig::Boundary::kExact);
  EXPECT_THROW(dm::demConfigForMethod("grids"), core::Error);
  const dm::DemConfig parametric = dm::parametricDemConfig(grid);
  EXPECT_TRUE(parametric.parametric.enabled);
  EXPECT_EQ(parametric.grid.spacings, 0.0);
  EXPECT_EQ(parametric.grid.body_cells, 0.0);
  EXPECT_EQ(parametric.adam.iterations, dm::kParametricAdamIterations);
  EXPECT_EQ(parametric.boundary.kind, dm::DemConfig::Boundary::kExact);

  // Each preset is a configuration the solver accepts (the grid alone refuses parametric mode and
  // the penalty boundary).
  const core::ParticleCloud cloud =
      dm::makeBoxParticles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
  const core::Scenario scenario = dm::uniaxialTractionScenario(1e5);
  for (const dm::DemConfig& config : {grid, mlp, parametric}) EXPECT_NO_THROW(dm::DemSolver(cloud, scenario, config));
  dm::DemConfig broken = grid;
  broken.parametric.enabled = true;
  EXPECT_THROW(dm::DemSolver(cloud, scenario, broken), core::Error);

  // A file applies over the method's preset.
  const std::string path = ::testing::TempDir() + "solver_config_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "dem:\n  adam_iterations: 200\ncontrol:\n  time_limit: 0\n";
  const dm::SimulateOptions o = dm::solverDefaults("mlp", path);
  EXPECT_EQ(o.dem.adam.iterations, 200);
  EXPECT_EQ(o.dem.lbfgs.iterations, dm::paperDemConfig().lbfgs.iterations);
  EXPECT_EQ(o.control.time_limit, 0.0);
  std::remove(path.c_str());
}
