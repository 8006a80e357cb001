// `demnerf simulate`: quasi-static deformation of a particle cloud under a scenario, by the Deep
// Energy Method, the FEM baseline or the strong-form PINN baseline (packages/mechanics). Writes
// one result row per particle.

#include <cstdlib>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/simulate.hpp"

namespace demnerf::cli {
namespace {

Figures runSimulate(const Arguments& arguments) {
  arguments.rejectUnknown({"particles", "scenario", "solver", "mesh", "out", "cell", "order", "iterations", "width",
                           "depth", "boundary", "threads", "json", "quiet", "save-model", "load-range", "newton", "grid-cell", "grid-spacings", "mesher"});
  const std::string solver_name = arguments.text("solver", "dem");
  if (solver_name != "dem" && solver_name != "fem" && solver_name != "pinn")
    throw UsageError("option --solver expects dem, fem or pinn, got '" + solver_name + "'");
  const mechanics::SolverChoice solver = mechanics::parseSolverChoice(solver_name);
  const std::string out_path = arguments.text("out");
  const core::ParticleCloud cloud = core::readParticles(arguments.text("particles"));
  const core::Scenario scenario = core::loadScenario(arguments.text("scenario"));

  mechanics::SimulateOptions options;
  options.voxel.cell = arguments.number("cell", 0.0);
  options.voxel.order = arguments.integer("order", 2);
  if (options.voxel.order != 1 && options.voxel.order != 2)
    throw UsageError("option --order expects 1 (TET4) or 2 (TET10), got " + std::to_string(options.voxel.order));
  if (options.voxel.cell < 0) throw UsageError("option --cell expects a positive length in metres (0: automatic)");
  if (arguments.has("mesh")) options.surface = core::readMesh(arguments.text("mesh"));
  // How --mesh is meshed for the FEM: CGAL tetrahedra that follow the surface, or voxels.
  const std::string mesher = arguments.text("mesher", "cgal");
  if (mesher == "voxel") options.mesher = mechanics::SimulateOptions::Mesher::kVoxel;
  else if (mesher != "cgal") throw UsageError("option --mesher expects cgal or voxel, got '" + mesher + "'");
  options.dem.adam_iterations = arguments.integer("iterations", options.dem.adam_iterations);
  options.dem.width = arguments.integer("width", options.dem.width);
  options.dem.depth = arguments.integer("depth", options.dem.depth);
  options.dem.threads = arguments.integer("threads", 0);
  // The PINN takes the same network and iteration flags (its own defaults when absent).
  options.pinn.adam_iterations = arguments.integer("iterations", options.pinn.adam_iterations);
  options.pinn.width = arguments.integer("width", options.pinn.width);
  options.pinn.depth = arguments.integer("depth", options.pinn.depth);
  options.pinn.threads = options.dem.threads;
  // DEM extras: a saved network for `demnerf predict`, the parametric load range (instant answers
  // for any load fraction in it) and the output-layer Newton solve.
  if (arguments.has("save-model")) {
    if (solver != mechanics::SolverChoice::kDem) throw UsageError("option --save-model needs --solver dem");
    options.dem_model_path = arguments.text("save-model");
  }
  if (arguments.has("load-range")) {
    const std::string range = arguments.text("load-range");
    const auto comma = range.find(',');
    char* end = nullptr;
    const double lo = std::strtod(range.c_str(), &end);
    const double hi = comma == std::string::npos ? 0.0 : std::strtod(range.c_str() + comma + 1, nullptr);
    if (comma == std::string::npos || end != range.c_str() + comma || !(lo < hi))
      throw UsageError("option --load-range expects MIN,MAX load fractions with MIN < MAX (e.g. 0,1.5), got '" + range + "'");
    options.dem.parametric = true;
    options.dem.load_range_min = lo;
    options.dem.load_range_max = hi;
  }
  if (arguments.has("newton")) options.dem.output_newton = true;
  // The DEM's feature grid (DemConfig::grid_cell): its Newton solve is the training, so Adam runs
  // only when --iterations asks for it.
  if (arguments.has("grid-cell")) {
    options.dem.grid_cell = arguments.number("grid-cell", 0.0);
    if (!(options.dem.grid_cell > 0))
      throw UsageError("option --grid-cell expects the feature grid's cell edge in metres (> 0; about two particle spacings)");
  }
  if (arguments.has("grid-spacings")) {
    options.dem.grid_spacings = arguments.number("grid-spacings", 0.0);
    if (!(options.dem.grid_spacings > 0))
      throw UsageError("option --grid-spacings expects the feature grid's cell in particle spacings (> 0; 2 is a good choice)");
  }
  if ((arguments.has("grid-cell") || arguments.has("grid-spacings")) && !arguments.has("iterations"))
    options.dem.adam_iterations = 0;
  const std::string boundary = arguments.text("boundary", "exact");
  if (boundary == "penalty") options.dem.boundary = mechanics::DemConfig::Boundary::kPenalty;
  else if (boundary != "exact") throw UsageError("option --boundary expects exact or penalty, got '" + boundary + "'");

  const mechanics::SimulationOutcome outcome = mechanics::simulate(cloud, scenario, solver, options);
  core::writeResult(out_path, outcome.field);
  Figures figures{{"seconds", outcome.seconds},
                  {"energy", outcome.energy},
                  {"max_displacement", outcome.max_displacement},
                  {"particles", cloud.size()},
                  {"solver", solver_name},
                  {"out", out_path}};
  if (solver == mechanics::SolverChoice::kPinn) figures["loss"] = outcome.loss;
  if (solver == mechanics::SolverChoice::kFem) {
    figures["mesh_nodes"] = outcome.mesh_nodes;
    figures["mesh_elements"] = outcome.mesh_elements;
  }
  return figures;
}

}  // namespace

const Command kSimulateCommand = {
    "simulate", "quasi-static deformation of a particle cloud",
    "--particles P.ply --scenario S.yaml --solver dem|fem|pinn [--mesh M.ply [--mesher cgal|voxel]] --out R.ply "
    "[--cell H] [--order 1|2] [--iterations N] [--width W] [--depth D] [--boundary exact|penalty] "
    "[--threads T] [--save-model M.dem] [--load-range MIN,MAX] [--newton] [--grid-cell H | --grid-spacings S] [--json]",
    runSimulate};

}  // namespace demnerf::cli
