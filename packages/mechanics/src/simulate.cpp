#include "demnerf/mechanics/simulate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"

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
      VoxelMeshConfig voxel = options.voxel;
      TetMesh mesh;
      if (options.surface) {
        if (voxel.cell == 0.0) {
          std::vector<double> v;
          for (double x : cloud.volumes)
            if (x > 0) v.push_back(x);
          std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
          voxel.cell = std::cbrt(v[v.size() / 2]);
        }
        if (options.mesher == SimulateOptions::Mesher::kCgal) {
          CgalMeshConfig cgal;
          cgal.cell = voxel.cell;
          cgal.order = voxel.order;
          mesh = cgalMeshFromSurface(*options.surface, cgal);
        } else {
          mesh = voxelMeshFromSurface(*options.surface, voxel);
        }
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
      FemSolver fem(std::move(mesh), scenario, options.fem);
      out.energy = fem.solve().energy;
      const PointField at = fem.interpolate(cloud.positions);
      out.field.positions = cloud.positions;
      out.field.displacements = at.displacement;
      out.field.von_mises = at.von_mises;
      break;
    }
    case SolverChoice::kPinn: {
      PinnSolver pinn(cloud, scenario, options.pinn);
      const PinnReport report = pinn.solve();
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
