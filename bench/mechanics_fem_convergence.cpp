// Is the FEM's default mesh converged on a scenario? Solves it with mechanics::simulate() (the
// path `demnerf simulate --solver fem` and the solver matrix take) at the automatic cell and at
// finer cells (elements_across times each factor), and prints one Markdown row per level with the
// rel. L2 and max error of u at the particles against the finest level, and the energy.
// Usage: mechanics_fem_convergence scenario=S.yaml particles=P.ply [surface=M.ply]
//          [factors=1,1.5] [order=2] [mesher=cgal|voxel] [time_limit=0 (none)] [out=PREFIX]
//   out=PREFIX writes each level's result PLY as PREFIX_<factor>.ply (the finest is the matrix's
//   reference; `demnerf compare` reads them).
// Example (T-bar): demnerf synth --scene tbar --out T; demnerf sample --mesh T/mesh.ply --method grid
//   --spacing 0.006 --out P.ply; mechanics_fem_convergence scenario=config/scenarios/tbar_twist.yaml
//   particles=P.ply surface=T/mesh.ply

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/compare_results.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "mechanics_bench_common.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;

int main(int argc, char** argv) {
  auto a = demnerf::bench::keyValueArguments(argc, argv);
  if (!a.count("scenario") || !a.count("particles")) {
    std::fprintf(stderr, "usage: mechanics_fem_convergence scenario=S.yaml particles=P.ply [surface=M.ply] "
                         "[factors=1,1.5] [order=2] [mesher=cgal|voxel] [time_limit=0] [out=PREFIX]\n");
    return 2;
  }
  try {
    const core::Scenario scenario = core::loadScenario(a["scenario"]);
    const core::ParticleCloud cloud = core::readParticles(a["particles"]);
    dm::SimulateOptions options;
    if (a.count("surface")) options.surface = core::readMesh(a["surface"]);
    if (a.count("mesher") && a["mesher"] == "voxel") options.mesher = dm::SimulateOptions::Mesher::kVoxel;
    options.voxel.order = a.count("order") ? std::atoi(a["order"].c_str()) : 2;
    options.control.time_limit = a.count("time_limit") ? std::atof(a["time_limit"].c_str()) : 0.0;
    // The solver's own progress, one line a second on stderr.
    options.control.progress = [](const dm::SolveProgress& p) {
      std::fprintf(stderr, "  %s %s: load %.3f, iteration %d, energy %.6g J, |r|/|f| %.2e, %.1f s\n", p.solver.c_str(),
                   p.phase.c_str(), p.load_fraction, p.iteration, p.energy, p.residual, p.elapsed);
    };
    std::vector<double> factors;
    {
      std::stringstream in(a.count("factors") ? a["factors"] : "1,1.5");
      for (std::string item; std::getline(in, item, ',');) factors.push_back(std::atof(item.c_str()));
    }
    const double across = options.voxel.elements_across;
    std::vector<dm::SimulationOutcome> levels;
    for (double f : factors) {
      dm::SimulateOptions level = options;
      level.voxel.elements_across = across * f;
      level.voxel.max_dofs = options.voxel.max_dofs * f * f * f;  // the cap refines with the level
      levels.push_back(dm::simulate(cloud, scenario, dm::SolverChoice::kFem, level));
      if (a.count("out")) {
        std::ostringstream path;
        path << a["out"] << "_" << f << ".ply";
        core::writeResult(path.str(), levels.back().field);
      }
      std::fprintf(stderr, "level x%g: cell %.2f mm, %d elements, %.1f s\n", f, levels.back().mesh_cell * 1e3,
                   levels.back().mesh_elements, levels.back().seconds);
    }
    std::printf("| scenario | mesh | cell (mm) | elements | nodes | seconds | energy (J) | rel. L2 vs finest | max error vs finest (mm) |\n");
    std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (std::size_t k = 0; k < levels.size(); ++k) {
      const dm::SimulationOutcome& o = levels[k];
      const bool finest = k + 1 == levels.size();
      const dm::ResultComparison c = finest ? dm::ResultComparison{} : dm::compareResults(o.field, levels.back().field);
      std::printf("| %s | %s TET%d x%g | %.2f | %d | %d | %.1f | %.6g | %s | %s |\n", scenario.name.c_str(),
                  options.surface && options.mesher == dm::SimulateOptions::Mesher::kCgal ? "CGAL" : "voxel",
                  options.voxel.order == 2 ? 10 : 4, factors[k], o.mesh_cell * 1e3, o.mesh_elements, o.mesh_nodes,
                  o.seconds, o.energy, finest ? "-" : (std::to_string(100 * c.rel_l2) + " %").c_str(),
                  finest ? "-" : std::to_string(c.max_error * 1e3).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mechanics_fem_convergence: %s\n", e.what());
    return 1;
  }
  return 0;
}
