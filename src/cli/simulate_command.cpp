// `demnerf simulate`: quasi-static deformation of a particle cloud under a scenario, by the Deep
// Energy Method, the FEM baseline or the strong-form PINN baseline (packages/mechanics). Writes
// one result row per particle. Settings: the DEM method's preset, then --config FILE, then flags
// (mechanics/solver_config_yaml.hpp); the help states the library's defaults.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "command.hpp"
#include "commands.hpp"
#include "simulate_settings.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"
#include "demnerf/vtk_export/vtu_writer.hpp"

namespace demnerf::cli {
namespace {

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// One line per report on stderr: what runs, how far the load is, and how close to equilibrium.
void printProgress(const mechanics::SolveProgress& p) {
  char residual[32] = "-";
  if (std::isfinite(p.residual)) std::snprintf(residual, sizeof residual, "%.2e", p.residual);
  std::fprintf(stderr, "simulate: %s %-7s load %.3f  iteration %5d  energy %+.6e J  residual %s  %6.1f s\n",
               p.solver.c_str(), p.phase.c_str(), p.load_fraction, p.iteration, p.energy, residual, p.elapsed);
}

Figures runSimulate(const Arguments& arguments) {
  arguments.rejectUnknown({"particles", "scenario", "solver", "mesh", "out", "cell", "order", "iterations", "width",
                           "depth", "boundary", "threads", "json", "quiet", "save-model", "load-range", "newton",
                           "grid-cell", "grid-spacings", "grid-body-cells", "mesher", "method", "config", "time-limit", "print-config",
                           "vtu"});
  mechanics::SimulateOptions options = simulateSettings(arguments);
  if (arguments.flag("print-config")) {
    std::cout << "# demnerf solver settings (demnerf simulate --config FILE, dem_node ~solver_config): every key\n"
                 "# with its value and meaning. Keys left out keep their defaults; unknown keys are errors.\n"
              << mechanics::solverConfigYaml(options);
    return Figures::object();
  }
  const std::string solver_name = arguments.text("solver", "dem");
  if (solver_name != "dem" && solver_name != "fem" && solver_name != "pinn")
    throw UsageError("option --solver expects dem, fem or pinn, got '" + solver_name + "'");
  const mechanics::SolverChoice solver = mechanics::parseSolverChoice(solver_name);
  const std::string out_path = arguments.text("out");
  const core::ParticleCloud cloud = core::readParticles(arguments.text("particles"));
  const core::Scenario scenario = core::loadScenario(arguments.text("scenario"));
  if (options.dem.tune_allocator) mechanics::keepLargeAllocationsInHeap();  // DemConfig::tune_allocator, process-wide
  if (arguments.has("mesh")) options.surface = core::readMesh(arguments.text("mesh"));
  if (arguments.has("save-model")) {
    if (solver != mechanics::SolverChoice::kDem) throw UsageError("option --save-model needs --solver dem");
    options.dem_model_path = arguments.text("save-model");
  }
  if (!arguments.flag("quiet")) options.control.progress = printProgress;
  const std::string vtu_path = arguments.has("vtu") ? arguments.text("vtu") : std::string();
  if (arguments.has("vtu") && vtu_path.empty()) throw UsageError("option --vtu expects a file name, e.g. out.vtu");
  // Before the solve, not after it: a typo in the folder must not cost the solve's minutes.
  const std::filesystem::path vtu_folder = std::filesystem::path(vtu_path).parent_path();
  if (!vtu_path.empty() && !vtu_folder.empty() && !std::filesystem::is_directory(vtu_folder))
    throw UsageError("option --vtu: the folder " + vtu_folder.string() + " does not exist");
  options.keep_fem_mesh = !vtu_path.empty() && solver == mechanics::SolverChoice::kFem;

  mechanics::SimulationOutcome outcome;
  try {
    outcome = mechanics::simulate(cloud, scenario, solver, options);
    if (!outcome.unverified.empty()) std::cerr << "demnerf simulate: warning: not verified: " << outcome.unverified << "\n";
    if (!outcome.coarse_grid.empty()) std::cerr << "demnerf simulate: warning: " << outcome.coarse_grid << "\n";
    if (outcome.held_unknowns > 0)
      std::cerr << "demnerf simulate: note: " << outcome.held_unknowns << " grid unknowns the body barely touches were held "
                << "(a singular Hessian: a ragged or sliver surface); the equilibrium is the body's with them held, and "
                << "their own residual is " << outcome.held_residual << " of the load\n";
  } catch (const mechanics::SolveError& error) {
    // One line that names the cause (exit 1): scripts can tell a time limit from a divergence.
    std::string message = error.what();
    for (char& c : message)
      if (c == '\n') c = ' ';
    throw core::Error(std::string("solve failed (") + mechanics::solveFailureName(error.failure()) + "): " + message);
  }
  core::writeResult(out_path, outcome.field);
  if (!vtu_path.empty()) {
    // ParaView: the FEM's own mesh and nodal solution when there is one, else the particles.
    if (outcome.fem_mesh)
      vtk_export::writeTetMeshVtu(vtu_path, outcome.fem_mesh->mesh, outcome.fem_mesh->displacement,
                                  outcome.fem_mesh->von_mises);
    else
      vtk_export::writeParticlesVtu(vtu_path, cloud, outcome.field);
  }
  Figures figures{{"seconds", outcome.seconds},
                  {"energy", outcome.energy},
                  {"max_displacement", outcome.max_displacement},
                  {"particles", cloud.size()},
                  {"solver", solver_name},
                  {"out", out_path}};
  if (!vtu_path.empty()) figures["vtu"] = vtu_path;
  if (solver == mechanics::SolverChoice::kDem) {
    figures["method"] = arguments.text("method", "grid");
    if (std::isfinite(outcome.residual)) figures["residual"] = outcome.residual;
    figures["held_unknowns"] = outcome.held_unknowns;
    if (outcome.held_unknowns > 0) figures["held_residual"] = outcome.held_residual;
  }
  if (solver == mechanics::SolverChoice::kPinn) figures["loss"] = outcome.loss;
  if (solver == mechanics::SolverChoice::kFem) {
    figures["mesh_nodes"] = outcome.mesh_nodes;
    figures["mesh_elements"] = outcome.mesh_elements;
  }
  return figures;
}

/// The usage text with every flag's default taken from the library (solverDefaults), so the help
/// cannot drift from what runs.
const char* usage() {
  static const std::string text = [] {
    const mechanics::SimulateOptions d = mechanics::solverDefaults();
    const mechanics::DemConfig mlp = mechanics::paperDemConfig();
    std::ostringstream u;
    u << "--particles P.ply --scenario S.yaml --out R.ply [options]\n"
         "Quasi-static deformation of the particles under the scenario; one result row per particle.\n"
         "Settings: the DEM method's preset, then --config FILE, then the flags given here.\n"
         "  --particles P.ply      particles with volumes, e.g. from `demnerf sample` (required)\n"
         "  --scenario S.yaml      material, fixtures and loads, e.g. config/scenarios/*.yaml (required)\n"
         "  --out R.ply            result: rest position, displacement, von Mises stress per particle (required)\n"
         "  --solver dem|fem|pinn  default dem: Deep Energy Method; fem: FEM baseline; pinn: strong-form PINN\n"
         "  --vtu OUT.vtu          also write the answer for ParaView (VTK XML unstructured grid): the particles\n"
         "                         as vertices, or with --solver fem the FEM's tetrahedra, with point data\n"
         "                         displacement, von_mises and volume (default: not written)\n"
         "  --config FILE          solver settings YAML (config/solvers.yaml lists every key with its default)\n"
         "  --time-limit S         default "
      << number(d.control.time_limit)
      << ": seconds a solve may run before it stops with an error (0: no limit)\n"
         "  --quiet                no progress (default: one line per second on stderr while solving)\n"
         "  --print-config         print the settings these options give, as a --config file, and exit\n"
         "  --json                 last line of stdout: the figures as one JSON object\n"
         "DEM:\n"
         "  --method grid|mlp      default grid: the MLP plus a B-spline feature grid sized from the body,\n"
         "                         integrated in its cells, solved by Newton; mlp: the paper's DEM, the MLP\n"
         "                         alone ("
      << mlp.network.width << " x " << mlp.network.depth << ") trained by "
      << mlp.lbfgs.iterations << " L-BFGS iterations on jittered particles,\n"
         "                         fixtures held exactly (--boundary penalty: the paper's W_u)\n"
         "  --grid-body-cells N    default "
      << number(d.dem.grid.body_cells)
      << ": cell = (V / N)^(1/3) from the body's volume (never finer than the particles,\n"
         "                         nor than six cells across the mean thickness 4V/A: grid.thickness_cells,\n"
         "                         nor than sqrt(A / 2000) for a ragged surface of area A: grid.surface_cells;\n"
         "                         0.8 of it on a rough surface, a NeRF extraction's: grid.rough_surface)\n"
         "  --grid-spacings S      default "
      << number(d.dem.grid.spacings)
      << " (off): cell in particle spacings instead (below 1.5 is refused with the particle\n"
         "                         quadrature, grid: {quadrature: particles} in --config; docs/dem_feature_grid.md)\n"
         "  --grid-cell H          default "
      << number(d.dem.grid.cell)
      << " (off): cell edge in m; takes precedence over both; any grid flag sets Adam to 0\n"
         "  --iterations N         Adam iterations per load step (default: grid "
      << d.dem.adam.iterations << ", mlp " << mlp.adam.iterations << ", PINN " << d.pinn.adam_iterations
      << ")\n"
         "  --width W, --depth D   MLP hidden units per layer and hidden layers (default "
      << d.dem.network.width << ", " << d.dem.network.depth << "; mlp " << mlp.network.width << ", "
      << mlp.network.depth << "; PINN " << d.pinn.width << ", " << d.pinn.depth
      << ")\n"
         "  --boundary exact|penalty  fixtures held exactly, u = g + D z (the default of both methods), or by\n"
         "                         the paper's penalty W_u MSE_u (MLP alone; the feature grid needs exact)\n"
         "  --newton               Newton on the MLP's output layer (MLP alone, exact boundary; default off)\n"
         "  --load-range MIN,MAX   parametric: train the MLP once over these load fractions (contains 1), then\n"
         "                         `demnerf predict --load-scale` answers any of them (default off)\n"
         "  --save-model M.dem     save the trained DEM for `demnerf predict` (default: not saved)\n"
         "  --threads T            torch threads of the DEM and PINN (default "
      << d.dem.threads
      << ": 1 below 50k particles, else all cores;\n"
         "                         the MLP's fused kernel: one per 1000 points, up to all cores)\n"
         "FEM:\n"
         "  --mesh M.ply           mesh this closed surface (default: the surface the particles' normals describe,\n"
         "                         as `demnerf sample` makes them; particles without normals: their cells)\n"
         "  --mesher cgal|voxel    default "
      << (d.mesher == mechanics::SimulateOptions::Mesher::kCgal ? "cgal" : "voxel")
      << ": CGAL Mesh_3 tetrahedra that follow the surface; voxel: voxels inside --mesh,\n"
         "                         or without it the blocks of particle cells the particles fill\n"
         "  --cell H               default "
      << number(d.voxel.cell)
      << " (automatic): mesh size in m (hex edge, or CGAL tetrahedron edge)\n"
         "  --order 1|2            default "
      << d.voxel.order << ": 1 linear (TET4), 2 quadratic (TET10) tetrahedra";
    return u.str();
  }();
  return text.c_str();
}

}  // namespace

const Command kSimulateCommand = {"simulate", "quasi-static deformation of a particle cloud", usage(), runSimulate};

}  // namespace demnerf::cli
