// Cook's membrane with the FEM baseline: tip y-displacement against the deal.II reference
// (14.33 mm) for linear and quadratic tetrahedra over mesh refinement, and the linear solvers.
// Usage: mechanics_cook [max_cells]   (default 32)

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/reference_problems.hpp"

namespace dm = demnerf::mechanics;

int main(int argc, char** argv) {
  const int max_cells = argc > 1 ? std::atoi(argv[1]) : 32;
  // Two candidate points for the reference figure: the top right corner (48, 60) and the midpoint
  // of the loaded edge (48, 52), which is where deal.II's code gallery evaluates its solution.
  std::printf("| elements | cells/edge | dofs | solver | uy(48,60) (mm) | vs 14.33 | uy(48,52) (mm) | vs 14.33 | Newton its | seconds |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (int order : {1, 2})
    for (int cells = 4; cells <= max_cells; cells *= 2)
      for (auto solver : {dm::FemConfig::LinearSolver::kLDLT, dm::FemConfig::LinearSolver::kConjugateGradient}) {
        if (solver == dm::FemConfig::LinearSolver::kConjugateGradient && cells < max_cells) continue;
        dm::FemConfig config;
        config.linear_solver = solver;
        dm::FemSolver fem(dm::cookMembraneMesh(cells, order), dm::cookMembraneScenario(), config);
        const dm::FemResult& r = fem.solve();
        const auto at = fem.interpolate({dm::cookMembraneTip(), Eigen::Vector3d(48e-3, 52e-3, 0.5e-3)}).displacement;
        const double tip = at[0].y(), mid = at[1].y();
        std::printf("| %s | %d | %zu | %s | %.3f | %+.2f %% | %.3f | %+.2f %% | %d | %.2f |\n", order == 1 ? "TET4" : "TET10",
                    cells, 3 * fem.mesh().nodes.size(), solver == dm::FemConfig::LinearSolver::kLDLT ? "LDLT" : "CG+IC",
                    tip * 1e3, 100.0 * (tip - dm::kCookTipReference) / dm::kCookTipReference, mid * 1e3,
                    100.0 * (mid - dm::kCookTipReference) / dm::kCookTipReference, r.newton_iterations, r.seconds);
        std::fflush(stdout);
      }
  return 0;
}
