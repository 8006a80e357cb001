#include "demnerf/mechanics/simulate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/mesh_size.hpp"

namespace demnerf::mechanics {

SolverChoice parseSolverChoice(const std::string& name) {
  if (name == "dem") return SolverChoice::kDem;
  if (name == "fem") return SolverChoice::kFem;
  if (name == "pinn") return SolverChoice::kPinn;
  throw core::Error("unknown solver '" + name + "': use dem, fem or pinn");
}

const char* solverName(SolverChoice solver) {
  switch (solver) {
    case SolverChoice::kDem: return "dem";
    case SolverChoice::kFem: return "fem";
    case SolverChoice::kPinn: return "pinn";
  }
  return "?";
}

namespace {

// Edge of a particle's cell: the cube root of the median particle volume (a grid sampler's spacing).
double medianParticleEdge(const core::ParticleCloud& cloud) {
  std::vector<double> v;
  for (double x : cloud.volumes)
    if (x > 0) v.push_back(x);
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return std::cbrt(v[v.size() / 2]);
}

}  // namespace

SimulationOutcome simulate(const core::ParticleCloud& cloud, const core::Scenario& scenario, SolverChoice solver,
                           const SimulateOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  // Every solver checks the same things first, so bad input fails the same way before any work.
  validateProblem(scenario, cloud);
  SimulationOutcome out;
  switch (solver) {
    case SolverChoice::kDem: {
      DemSolver dem(cloud, scenario, options.dem);
      dem.setControl(options.control);
      out.energy = dem.solve().energy;
      out.field = dem.result();
      if (!options.dem_model_path.empty()) saveDemModel(dem, options.dem_model_path);
      break;
    }
    case SolverChoice::kFem: {
      SolveClock clock(options.control, "fem");
      const bool cgal = options.surface && options.mesher == SimulateOptions::Mesher::kCgal;
      VoxelMeshConfig voxel = options.voxel;
      if (voxel.cell == 0.0) {
        // From the body and the accuracy asked for, not from how finely it was sampled.
        const BodyMeasures body = options.surface ? measureSurface(*options.surface) : measureParticles(cloud);
        voxel.cell = automaticCell(body, MeshSizeRule{voxel.elements_across, voxel.max_dofs, voxel.order});
        // Voxels of particles: a whole number of the particles' own cells (no finer: empty cells
        // would be holes), so a grid-sampled body keeps its faces.
        if (!options.surface) {
          const double spacing = medianParticleEdge(cloud);
          if (spacing > 0.0) voxel.cell = spacing * std::max(1.0, std::round(voxel.cell / spacing));
        }
      }
      // Say what is being built before the (uninterruptible) meshing and first factorisation.
      SolveProgress meshing;
      {
        const double volume = options.surface ? measureSurface(*options.surface).volume : measureParticles(cloud).volume;
        std::ostringstream phase;
        phase << (cgal ? "mesh (CGAL, " : "mesh (voxels, ") << (voxel.order == 2 ? "TET10" : "TET4") << ", cell "
              << voxel.cell * 1e3 << " mm, ~" << std::lround(expectedDofs(volume, voxel.cell, voxel.order)) << " dofs)";
        meshing.phase = phase.str();
      }
      meshing.residual = std::numeric_limits<double>::quiet_NaN();
      clock.report(meshing, true);
      TetMesh mesh;
      if (cgal) {
        CgalMeshConfig config;
        config.cell = voxel.cell;
        config.order = voxel.order;
        mesh = cgalMeshFromSurface(*options.surface, config);
      } else if (options.surface) {
        mesh = voxelMeshFromSurface(*options.surface, voxel);
      } else {
        mesh = voxelMeshFromParticles(cloud, voxel);
      }
      // Specks of a reconstructed body that touch no fixture would make the stiffness singular.
      mesh = keepHeldPieces(mesh, [&](const Eigen::Vector3d& x) {
        for (const core::Fixture& f : scenario.fixtures)
          if (f.region.contains(x)) return true;
        return false;
      });
      out.mesh_nodes = static_cast<int>(mesh.nodes.size());
      out.mesh_elements = static_cast<int>(mesh.elements.size());
      out.mesh_cell = voxel.cell;
      clock.check("no state (meshing took the budget: " + std::to_string(out.mesh_elements) +
                  " elements at a cell of " + std::to_string(voxel.cell) + " m; pass a larger --cell)");
      FemSolver fem(std::move(mesh), scenario, options.fem);
      out.energy = fem.solve(clock).energy;
      const PointField at = fem.interpolate(cloud.positions);
      out.field.positions = cloud.positions;
      out.field.displacements = at.displacement;
      out.field.von_mises = at.von_mises;
      if (options.keep_fem_mesh) {
        auto kept = std::make_shared<FemMeshSolution>();
        kept->mesh = fem.mesh();
        kept->displacement = fem.result().displacement;
        // Stress is per element (discontinuous across faces); at a node, the element that
        // locates it gives it, as at any other point.
        kept->von_mises = fem.interpolate(kept->mesh.nodes).von_mises;
        out.fem_mesh = std::move(kept);
      }
      break;
    }
    case SolverChoice::kPinn: {
      PinnSolver pinn(cloud, scenario, options.pinn);
      const PinnReport report = pinn.solve(options.control);
      out.energy = report.energy;  // of the trained field: the PINN minimises residuals, not energy
      out.loss = report.loss;
      out.field = pinn.result();
      break;
    }
  }
  for (const auto& u : out.field.displacements) out.max_displacement = std::max(out.max_displacement, u.norm());
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace demnerf::mechanics
