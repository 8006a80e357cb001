#include "demnerf/mechanics/simulate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"
#include "demnerf/mechanics/held_volume_planes.hpp"
#include "demnerf/mechanics/mesh_size.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"
#include "demnerf/mechanics/particle_surface.hpp"

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

/// A surface of particles with more than this share of rough particles is bumpy or curved
/// (ParticleInsideTest::roughShare): its FEM mesh follows it only as closely as the particles place it.
constexpr double kRoughSurfaceShare = 0.5;

/// The surface a cloud's surface particles describe (particleSurface), and whether most of them are
/// rough, both from one inside test.
struct ParticlesSurface {
  core::TriangleMesh mesh;
  bool rough = false;
};

/// The voxel (or CGAL) cell of an automatic FEM mesh: from the body and the accuracy asked for,
/// not from how finely it was sampled. Voxels of particles (a cloud whose particles do not place
/// its surface) are a whole number of the particles' own cells (no finer: empty cells would be
/// holes), so a grid-sampled body keeps its faces; over a cloud that is no lattice, at least two,
/// which the particles fill to half on any sampler. One-spacing voxels of a Poisson cloud can meet
/// only at an edge, a hinge on which Newton stalled.
VoxelMeshConfig femVoxels(const core::ParticleCloud& cloud, const core::TriangleMesh* surface, const BodyMeasures& body,
                          VoxelMeshConfig voxel) {
  if (voxel.cell != 0.0) return voxel;
  voxel.cell = automaticCell(body, MeshSizeRule{voxel.elements_across, voxel.max_dofs, voxel.order});
  if (!surface) {
    const double spacing = medianParticleEdge(cloud);
    const double fewest = particlesFormALattice(cloud) ? 1.0 : 2.0;
    if (spacing > 0.0) voxel.cell = spacing * std::max(fewest, std::round(voxel.cell / spacing));
  }
  return voxel;
}

/// Says what is being built before the (uninterruptible) meshing and first factorisation.
void reportMeshing(double volume, bool of_particles, const VoxelMeshConfig& voxel, bool cgal, SolveClock& clock) {
  SolveProgress meshing;
  std::ostringstream phase;
  phase << (cgal ? "mesh (CGAL, " : "mesh (voxels, ") << (voxel.order == 2 ? "TET10" : "TET4") << ", cell "
        << voxel.cell * 1e3 << " mm, ~" << std::lround(expectedDofs(volume, voxel.cell, voxel.order)) << " dofs"
        << (of_particles ? ", of the particles' surface)" : ")");
  meshing.phase = phase.str();
  meshing.residual = std::numeric_limits<double>::quiet_NaN();
  clock.report(meshing, true);
}

/// Says what the mesher made: its size is known only now (a bumpy surface refines it past the
/// estimate reportMeshing gave), and the solve's cost follows it.
/// Pieces that touch no fixture or hang on by an edge or a corner, dropped from the mesh.
struct DroppedPieces {
  std::size_t tetrahedra = 0;
  double volume_share = 0.0;  ///< of the whole mesh's volume
};

/// `dropped`: what keepHeldPieces took out; its share of the volume says whether the solve still
/// runs on the body (a few slivers) or on part of it.
void reportMesh(const TetMesh& mesh, const DroppedPieces& dropped, SolveClock& clock) {
  SolveProgress meshed;
  std::ostringstream phase;
  phase << "meshed: " << mesh.elements.size() << " tetrahedra, " << 3 * mesh.nodes.size() << " dofs";
  if (dropped.tetrahedra > 0)
    phase << " (dropped " << dropped.tetrahedra << " tetrahedra of loose or hinged pieces, "
          << std::setprecision(2) << 100.0 * dropped.volume_share << " % of the volume)";
  meshed.phase = phase.str();
  meshed.residual = std::numeric_limits<double>::quiet_NaN();
  clock.report(meshed, true);
}

/// CGAL's mesh of the surface. Mesh_3 follows it to within a tenth of the cell. On a rough surface
/// of particles that is their sampling's kinks wherever the particles are coarser than the cell:
/// the bumps between their planes say where the surface is only to about a tenth of their spacing.
/// A 158-particle NeRF cuboid (the render rostest's cantilever, 20 mm spacing) got 31,640 TET10 and
/// 171k dofs at an 8.2 mm cell for a 60k budget: a 40 s solve, over a CI machine's 60 s limit;
/// within a tenth of the spacing (29 mm, the cube root of the median particle volume) 10k TET10 and
/// 8 s, energy 0.3 % apart. A flat-faced body's particles place its faces exactly and its
/// sharpened edges to the sampling step, so it keeps a tenth of the cell (a sampled block bent by
/// an end load went 0.8 -> 3.4 % from its own surface's energy at a tenth of the spacing).
/// `of_particles`: the particles' own surface (null: a given one).
TetMesh cgalFemMesh(const core::ParticleCloud& cloud, const core::Scenario& scenario, const core::TriangleMesh& surface,
                    const ParticlesSurface* of_particles, const VoxelMeshConfig& voxel) {
  CgalMeshConfig config;
  config.cell = voxel.cell;
  config.order = voxel.order;
  config.protect_creases = !of_particles;
  config.cut_planes = heldVolumePlanes(scenario, surface);
  if (of_particles && of_particles->rough)
    config.facet_distance = std::max(voxel.cell, medianParticleEdge(cloud)) / 10.0;
  return cgalMeshFromSurface(surface, config);
}

/// The FEM's mesh of the body: CGAL from the surface, or voxels of the surface or the particles;
/// specks of a reconstructed body that touch no fixture, and pieces that meet the body only at an
/// edge or a corner, are dropped (they would make the stiffness singular) and told in `dropped`.
TetMesh femMesh(const core::ParticleCloud& cloud, const core::Scenario& scenario, const core::TriangleMesh* surface,
                const ParticlesSurface* of_particles, const VoxelMeshConfig& voxel, bool cgal, DroppedPieces& dropped) {
  TetMesh mesh;
  if (cgal) {
    mesh = cgalFemMesh(cloud, scenario, *surface, of_particles, voxel);
  } else if (surface) {
    mesh = voxelMeshFromSurface(*surface, voxel);
  } else {
    mesh = voxelMeshFromParticles(cloud, voxel);
  }
  TetMesh kept = keepHeldPieces(mesh, [&](const Eigen::Vector3d& x) {
    for (const core::Fixture& f : scenario.fixtures)
      if (f.region.contains(x)) return true;
    return false;
  });
  dropped.tetrahedra = mesh.elements.size() - kept.elements.size();
  if (dropped.tetrahedra > 0) dropped.volume_share = 1.0 - tetMeshVolume(kept) / tetMeshVolume(mesh);
  return kept;
}

void solveDem(const core::ParticleCloud& cloud, const core::Scenario& scenario, const SimulateOptions& options,
              SimulationOutcome& out) {
  // Under the control from construction: the grid's set-up counts against the time limit.
  DemSolver dem(cloud, scenario, options.dem, options.control);
  const DemReport report = dem.solve();
  out.energy = report.energy;
  out.unverified = report.unverified;
  out.coarse_grid = report.coarse_grid;
  out.residual = report.residual;
  out.held_unknowns = report.held_unknowns;
  out.held_residual = report.held_residual;
  out.field = dem.result();
  if (!options.dem_model_path.empty()) saveDemModel(dem, options.dem_model_path);
}

/// The surface a sampled cloud's surface particles describe (surfaceOfParticles, sampled every
/// third of the cell), which the FEM's CGAL mesher meshes as it meshes a given surface, whichever
/// sampler made the cloud; none for a cloud whose particles do not place it. (The voxel mesher
/// keeps the blocks of particle cells: a lattice's own cells, nodes on its faces.) Voxel blocks that the particles
/// fill were ~40 mm on a Poisson cloud of the 0.125 m test cuboid (1.7x the energy of the body's
/// mesh) and left random clouds of the T-bar 37 % too soft (docs/dem_feature_grid.md, "The FEM on
/// a cloud without its surface").
std::optional<ParticlesSurface> particleSurface(const core::ParticleCloud& cloud, const VoxelMeshConfig& voxel) {
  if (!particlesDescribeSurface(cloud)) return std::nullopt;
  const MeshSizeRule rule{voxel.elements_across, voxel.max_dofs, voxel.order};
  const double cell = voxel.cell > 0.0 ? voxel.cell : automaticCell(measureParticles(cloud), rule);
  ParticleInsideTest inside(cloud);
  inside.setBlendRoughFaces(false);  // the nearest plane: see setBlendRoughFaces
  return ParticlesSurface{surfaceOfParticles(cloud, inside, cell / 3.0), inside.roughShare() > kRoughSurfaceShare};
}

void solveFem(const core::ParticleCloud& cloud, const core::Scenario& scenario, const SimulateOptions& options,
              SimulationOutcome& out) {
  SolveClock clock(options.control, "fem");
  const bool cgal_mesher = options.mesher == SimulateOptions::Mesher::kCgal;
  const std::optional<ParticlesSurface> of_particles =
      options.surface || !cgal_mesher ? std::nullopt : particleSurface(cloud, options.voxel);
  const core::TriangleMesh* surface = options.surface ? &*options.surface : of_particles ? &of_particles->mesh : nullptr;
  const bool cgal = surface && cgal_mesher;
  // Measured once: a reconstructed surface has 10^5 triangles.
  const BodyMeasures body = surface ? measureSurface(*surface) : measureParticles(cloud);
  const VoxelMeshConfig voxel = femVoxels(cloud, surface, body, options.voxel);
  reportMeshing(body.volume, of_particles.has_value(), voxel, cgal, clock);
  DroppedPieces dropped;
  TetMesh mesh = femMesh(cloud, scenario, surface, of_particles ? &*of_particles : nullptr, voxel, cgal, dropped);
  out.mesh_nodes = static_cast<int>(mesh.nodes.size());
  out.mesh_elements = static_cast<int>(mesh.elements.size());
  out.mesh_cell = voxel.cell;
  reportMesh(mesh, dropped, clock);
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
}

void solvePinn(const core::ParticleCloud& cloud, const core::Scenario& scenario, const SimulateOptions& options,
               SimulationOutcome& out) {
  PinnSolver pinn(cloud, scenario, options.pinn);
  const PinnReport report = pinn.solve(options.control);
  out.energy = report.energy;  // of the trained field: the PINN minimises residuals, not energy
  out.loss = report.loss;
  out.field = pinn.result();
}

}  // namespace

SimulationOutcome simulate(const core::ParticleCloud& cloud, const core::Scenario& scenario, SolverChoice solver,
                           const SimulateOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  // Every solver checks the same things first, so bad input fails the same way before any work.
  validateProblem(scenario, cloud);
  SimulationOutcome out;
  switch (solver) {
    case SolverChoice::kDem: solveDem(cloud, scenario, options, out); break;
    case SolverChoice::kFem: solveFem(cloud, scenario, options, out); break;
    case SolverChoice::kPinn: solvePinn(cloud, scenario, options, out); break;
  }
  for (const auto& u : out.field.displacements) out.max_displacement = std::max(out.max_displacement, u.norm());
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace demnerf::mechanics
