#pragma once
// One entry point for every solver: a particle cloud and a scenario in, a result field (one row
// per particle, in order) and the run's figures out. Backs `demnerf simulate` and the dem_node.

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/pinn_solver.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "demnerf/mechanics/voxel_mesh.hpp"

namespace demnerf::mechanics {

enum class SolverChoice { kDem, kFem, kPinn };

/// "dem" | "fem" | "pinn"; core::Error naming the bad value otherwise.
SolverChoice parseSolverChoice(const std::string& name);
const char* solverName(SolverChoice solver);

struct SimulateOptions {
  DemConfig dem;
  /// DEM: save the trained network here (`demnerf predict` and dem_node read it); empty: don't.
  std::string dem_model_path;
  FemConfig fem;
  PinnConfig pinn;
  /// FEM mesh: hexes of this size split into tetrahedra of voxel.order; with a surface and the
  /// CGAL mesher, the target tetrahedron edge and order of the CGAL mesh. Cell 0 (default):
  /// automatic, from the body's thickness and voxel.elements_across / max_dofs (see
  /// VoxelMeshConfig), not from the particle spacing.
  VoxelMeshConfig voxel;
  /// FEM: mesh this closed surface. Without it the CGAL mesher meshes the surface the particles
  /// describe (surfaceOfParticles, when their surface particles carry normals and no volume, as
  /// `demnerf sample` and the NeRF extraction make them); otherwise, and with the voxel mesher,
  /// the FEM meshes voxels of the cells holding particles.
  std::optional<core::TriangleMesh> surface;
  /// How a surface is meshed: CGAL Mesh_3 tetrahedra that follow the surface (sharp edges kept),
  /// or voxels whose centres lie inside it (staircased faces; no closedness check).
  enum class Mesher { kCgal, kVoxel };
  Mesher mesher = Mesher::kCgal;
  /// Time budget, progress sink and cancel flag of the solve (every solver honours them).
  SolveControl control;
  /// FEM: keep the mesh and its nodal solution in SimulationOutcome::fem_mesh (ParaView export).
  bool keep_fem_mesh = false;
};

/// The FEM's own answer: its mesh, the displacement at every node and the von Mises stress there.
struct FemMeshSolution {
  TetMesh mesh;
  std::vector<Eigen::Vector3d> displacement;
  std::vector<double> von_mises;
};

struct SimulationOutcome {
  core::ResultField field;
  double seconds = 0.0;           ///< wall time of meshing + solving + evaluation at the particles
  double energy = 0.0;            ///< total potential energy at full load (J)
  double loss = 0.0;              ///< PINN only: the weighted residual loss at full load
  double max_displacement = 0.0;  ///< largest |u| over the particles (m)
  int mesh_nodes = 0;             ///< FEM only
  int mesh_elements = 0;          ///< FEM only
  double mesh_cell = 0.0;         ///< FEM only: the cell (target edge) the mesh was made with (m)
  std::string unverified;         ///< parametric DEM only: why it failed its equilibrium check (DemReport)
  std::string coarse_grid;        ///< DEM: why the answer will be stiff (DemReport::coarse_grid)
  double residual = std::numeric_limits<double>::quiet_NaN();  ///< DEM grid: DemReport::residual
  long held_unknowns = 0;       ///< DEM grid: DemReport::held_unknowns
  double held_residual = 0.0;   ///< DEM grid: DemReport::held_residual
  /// FEM with options.keep_fem_mesh only; shared so that copies of the outcome stay cheap.
  std::shared_ptr<const FemMeshSolution> fem_mesh;
};

/// Solves the scenario on the particles. Throws core::Error for bad input (before any work) or a
/// failed solve.
SimulationOutcome simulate(const core::ParticleCloud& cloud, const core::Scenario& scenario, SolverChoice solver,
                           const SimulateOptions& options = {});

}  // namespace demnerf::mechanics
