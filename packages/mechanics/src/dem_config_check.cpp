#include "dem_config_check.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "surface_roughness.hpp"

namespace demnerf::mechanics {
namespace {

void checkNetwork(const DemConfig& config) {
  if (config.network.width < 1 || config.network.depth < 1) throw core::Error("DEM network needs width >= 1 and depth >= 1");
  if (config.network.activation != "tanh" && config.network.activation != "sigmoid" && config.network.activation != "softplus" &&
      config.network.activation != "sin")
    throw core::Error("unknown DEM activation '" + config.network.activation + "': use tanh, sigmoid, softplus or sin");
  if (config.parametric.enabled && !(std::isfinite(config.parametric.load_range_min) && std::isfinite(config.parametric.load_range_max) &&
                             config.parametric.load_range_min < config.parametric.load_range_max && config.parametric.load_range_min <= 1.0 &&
                             config.parametric.load_range_max >= 1.0))
    throw core::Error("DEM parametric load range [" + std::to_string(config.parametric.load_range_min) + ", " +
                      std::to_string(config.parametric.load_range_max) +
                      "] must be finite, ordered and contain 1 (the scenario's own load, which result() reports)");
  if (config.load_steps < 0) throw core::Error("DEM load_steps must be >= 0 (0: the scenario's)");
}

void checkGridSettings(const DemConfig& config) {
  if (config.grid.cell < 0 || !std::isfinite(config.grid.cell) || config.grid.spacings < 0 ||
      !std::isfinite(config.grid.spacings) || !(config.grid.body_cells >= 0) || !std::isfinite(config.grid.body_cells))
    throw core::Error("DEM grid.cell, grid.spacings and grid.body_cells must be finite and >= 0 (0: no feature grid)");
  if (!(config.grid.surface_share >= 0 && config.grid.surface_share <= 1) || !(config.grid.refine_band >= 0) ||
      !std::isfinite(config.grid.refine_band))
    throw core::Error("DEM grid.surface_share must lie in [0, 1] and grid.refine_band be finite and >= 0");
  if (config.grid.nested_levels < 0 || config.grid.nested_levels > 4 || !(config.grid.nested_ratio > 1) ||
      !std::isfinite(config.grid.nested_ratio))
    throw core::Error("DEM grid.nested_levels must lie in [0, 4] and grid.nested_ratio be finite and > 1");
  if (!(config.grid.thickness_cells >= 0) || !std::isfinite(config.grid.thickness_cells) ||
      !(config.grid.surface_cells >= 0) || !std::isfinite(config.grid.surface_cells))
    throw core::Error("DEM grid.thickness_cells and grid.surface_cells must be finite and >= 0 (0: off)");
  if (!(config.grid.rough_surface >= 0) || !std::isfinite(config.grid.rough_surface) ||
      !(config.grid.rough_cell_ratio > 0 && config.grid.rough_cell_ratio <= 1))
    throw core::Error("DEM grid.rough_surface must be finite and >= 0 (0: off) and grid.rough_cell_ratio lie in (0, 1]");
}

// A resolved grid against the particles that integrate it or carry its loads.
// The finest cell the cells' rule takes, in (90th-percentile) particle spacings. 0.75 coarsened a
// random 432-particle cube (90th percentile 19.8 mm at a 16.7 mm sampler spacing) from the body's
// 11.9 mm cells to 14.8 mm, where its 30 % compression came out 5.5 % off (1.5 % at 11.9 mm).
constexpr double kFinestCellInSpacings = 0.6;

void checkGridAgainstParticles(const DemConfig& config, double spacing) {
  if (config.grid.cell > 0 && (config.parametric.enabled || config.boundary.kind != DemConfig::Boundary::kExact ||
                               config.output_newton.enabled))
    throw core::Error(
        "the DEM feature grid (grid.cell > 0) needs the exact boundary mode and works without parametric mode and "
        "the output-layer Newton; turn those off or set grid.cell = 0");
  const bool particles = config.grid.quadrature == DemConfig::GridQuadrature::kParticles;
  // The particles as quadrature: a cell of about one particle spacing has modes the particles
  // cannot see, and Newton finds them (a twisted bar: 80 % error at 1 spacing).
  if (config.grid.cell > 0 && particles && config.grid.cell < 1.5 * spacing)
    throw core::Error("DEM grid.cell " + std::to_string(config.grid.cell) + " m is below 1.5 particle spacings (" +
                      std::to_string(spacing) + " m): the particles cannot integrate the grid's finer modes; use " +
                      "about two spacings (" + std::to_string(2 * spacing) + " m) or more");
  // The cells' quadrature resolves the body to about one particle spacing, and the loads act on
  // the surface particles: cells much finer than that would see single particles as point loads.
  // (`spacing` is the 90th percentile's, above the mean spacing on Poisson and Voronoi clouds.)
  if (config.grid.cell > 0 && !particles && config.grid.cell < kFinestCellInSpacings * spacing)
    throw core::Error("DEM grid.cell " + std::to_string(config.grid.cell) + " m is finer than " +
                      std::to_string(kFinestCellInSpacings) + " particle spacings (" + std::to_string(spacing) +
                      " m), which resolve the body and its loads; use a coarser cell or finer particles");
}

}  // namespace

// Not the median: surface particles of sampled bodies carry partial volumes and can be the
// majority on slender ones (the demo's T-bar: median 4.4 mm on a 6 mm grid).
double interiorParticleSpacing(const core::ParticleCloud& cloud) {
  std::vector<double> volumes;
  for (double v : cloud.volumes)
    if (v > 0) volumes.push_back(v);
  if (volumes.empty()) return 0.0;
  const auto at = volumes.begin() + static_cast<long>(0.9 * (volumes.size() - 1));
  std::nth_element(volumes.begin(), at, volumes.end());
  return std::cbrt(*at);
}

namespace {

// Fewer cells than this across the mean thickness make a stiff answer: a 158-particle NeRF cuboid
// cantilever (the render rostest's, 2.7 cells) came out 13 % stiffer in energy than the FEM on the
// same particles; the matrix's coarsest clouds get the body's 6.
constexpr double kFewestCellsAcross = 4.0;

// What the user should know when the particles' floor, not the body, set a grid too coarse for it
// (empty when the grid is fine enough, or the body's own rules set it).
std::string coarseGridNote(double cell, double floor, double volume, double area, double spacing) {
  const double thickness = area > 0 ? 4.0 * volume / area : 0.0;
  if (!(thickness > 0) || cell > floor * (1 + 1e-9) || thickness / cell >= kFewestCellsAcross) return {};
  std::ostringstream note;
  note.precision(3);
  note << "the grid has " << thickness / cell << " cells across the body's mean thickness (4V/A = " << thickness * 1e3
       << " mm): the particles' spacing (" << spacing * 1e3 << " mm) keeps its cells at " << cell * 1e3
       << " mm or more, so expect a stiff answer (a 158-particle NeRF cuboid bent at 2.7 cells: 13 % stiffer in "
          "energy than the FEM on the same particles); particles at "
       << thickness / 6.0 * 1e3 << " mm (a sixth of the thickness) or finer let the grid take the body's own cells";
  return note.str();
}

// The cell a rough surface asks for: rough_cell_ratio of the body's when the surface particles
// scatter about their local quadric by more than rough_surface of the radius they are fitted over
// (two cells, at least three surface spacings: a quadric's six coefficients need the neighbours).
// Exactly sampled faces scatter 0; the NeRF T-bar's 1.5-2.4 %. The caller keeps it no finer than
// the particles resolve.
// A cloud with fewer particles than body_cells keeps its cell: the NeRF cuboid's random 1/10
// cloud (1,954 particles) is softer than its surface (its inside test rounds the loaded end), which
// the 10.3 mm grid's stiffness cancelled and the 8.24 mm one exposed (rel. L2 1.64 -> 2.01 %). The
// rule first compared the particles with the finer grid's body cells, for the cost: the NeRF
// T-bar's 1/6 clouds (3,400 particles, 3,900 cells at 7.88 mm) took 3 factorisations from a nested
// start the exact Hessian called indefinite; with the projected start (dem_grid_nested.cpp) they take
// one, and the finer cell brings their energy within 1 % (docs/dem_feature_grid.md, "A positive
// definite first fine step").
struct RoughSurfaceCell {
  double asked = 0.0;    ///< the finer cell a rough surface asks for (0: a smooth surface)
  double scatter = 0.0;  ///< surfaceRoughness() at `radius` (m); 0 where it was not measured
  double radius = 0.0;   ///< the radius the scatter was measured over (m)
  bool too_few = false;  ///< rough, but fewer particles than body_cells: the body's cell is kept
};

RoughSurfaceCell roughSurfaceCell(const DemConfig& config, const core::ParticleCloud& cloud) {
  const DemGridConfig& g = config.grid;
  RoughSurfaceCell rough;
  if (!(g.rough_surface > 0) || !(g.rough_cell_ratio < 1)) return rough;
  rough.radius = std::max(2 * g.cell, 3 * surfaceParticleSpacing(cloud));
  rough.scatter = surfaceRoughness(cloud, rough.radius);
  if (!(rough.scatter > g.rough_surface * rough.radius)) return rough;
  rough.asked = g.cell * g.rough_cell_ratio;
  rough.too_few = static_cast<double>(cloud.size()) < g.body_cells;
  return rough;
}

// What the user should know when the particles kept the cells coarser than their rough surface
// asks for (empty otherwise): too few of them, or their floor. The NeRF T-bar's Poisson 1/6 clouds
// (about 1,580 particles, 16.3 mm interior spacing) keep the body's 9.85 mm instead of 7.88, and
// over seven NeRF draws their energies were 1.8-3.8 % stiffer than the FEM's on the same particles,
// whose own answers were up to 2.4 % from the mesh's (docs/mechanics_matrix_nerf.md, "The FEM on
// the clouds' own surfaces" and "A warning where the particles hold the grid coarse").
std::string roughSurfaceNote(const RoughSurfaceCell& rough, const DemGridConfig& grid, std::size_t particles,
                             double cell, double floor) {
  if (!(rough.asked > 0) || !(cell > rough.asked * (1 + 1e-9))) return {};
  // How much closer the particles must be: enough of them, and a floor at the finer cell.
  double closer = std::min(1.0, rough.asked / floor);
  if (rough.too_few) closer = std::min(closer, std::cbrt(static_cast<double>(particles) / grid.body_cells));
  std::ostringstream note;
  note.precision(3);
  note << "the surface is rough (its particles scatter " << rough.scatter * 1e3 << " mm about a smooth fit over "
       << rough.radius * 1e3 << " mm) and asks for " << rough.asked * 1e3 << " mm cells, but ";
  if (rough.too_few)
    note << "its " << particles << " particles are fewer than the " << std::llround(grid.body_cells)
         << " (grid.body_cells) the finer grid needs";
  else
    note << "the particles' spacing allows no finer than " << floor * 1e3 << " mm";
  note << ", so the grid keeps " << cell * 1e3 << " mm: expect a stiff answer (the NeRF T-bar's Poisson clouds at a sixth "
       << "of its section: 1.8-3.8 % stiffer in energy than the FEM on the same particles; so sparse a cloud on a rough "
       << "surface fixes its body only to a few percent); particles " << closer << " times as far apart as these, or "
       << "closer, let the grid take the finer cell";
  return note.str();
}

// `first` and `second` joined, either possibly empty.
std::string joinedNotes(const std::string& first, const std::string& second) {
  if (first.empty() || second.empty()) return first + second;
  return first + "; " + second;
}

}  // namespace

ResolvedDemConfig resolvedDemConfig(DemConfig config, const core::ParticleCloud& cloud) {
  checkNetwork(config);
  checkGridSettings(config);
  const double spacing = interiorParticleSpacing(cloud);
  std::string coarse_grid;
  if (config.grid.cell == 0 && config.grid.spacings > 0) config.grid.cell = config.grid.spacings * spacing;
  if (config.grid.cell == 0 && config.grid.body_cells > 0) {
    double volume = 0.0, area = 0.0;
    for (double v : cloud.volumes) volume += std::max(v, 0.0);
    for (double a : cloud.areas) area += std::max(a, 0.0);
    // Never finer than the particles resolve (checkGridAgainstParticles). The particle quadrature
    // needs particles in every cell: one spacing. The cells' rule needs less; a clamp at one
    // 90th-percentile spacing coarsened a Poisson cloud's grid to 3.5 cells across the T-bar's leg
    // (7 % error, against 2.7 % at the body's 4).
    const bool particles = config.grid.quadrature == DemConfig::GridQuadrature::kParticles;
    const double floor = (particles ? 1.0 : kFinestCellInSpacings) * spacing;
    std::string rough_note;
    config.grid.cell = std::max(std::cbrt(volume / config.grid.body_cells), floor);
    // A slender body needs the 2000 cells (the T-bar's 60 mm section: 6 cells of 10 mm, where 600
    // gave 4 of 15 mm and +1.6 .. +4.2 % in energy); a compact one does not, and there they cost
    // a nearly dense factor (the 0.1 m cube at 7.9 mm: past the 60 s limit). Six cells across the
    // mean thickness 4 V / A (a square bar's side, 2/3 of a cube's) decide: T-bar 10 mm, cube 11 mm.
    if (config.grid.thickness_cells > 0 && area > 0)
      config.grid.cell = std::max(config.grid.cell, 4.0 * volume / area / config.grid.thickness_cells);
    // A ragged surface is mostly cut cells: the fox's NeRF extraction (29.8 m^2 around 0.77 m^3, a
    // sponge of genus ~540) had ~5,600 of them at 2000 body cells, whose inside probes took 40 s
    // of set-up, and a grid finer than its tunnels resolves none of them. About surface_cells cells
    // meet the surface (T-bar ~1,300 at 10 mm, Cook 2.7 mm ~830: unchanged; fox 73 -> 122 mm).
    const double ragged = config.grid.surface_cells > 0 && area > 0 ? std::sqrt(area / config.grid.surface_cells) : 0.0;
    if (ragged > config.grid.cell) {
      config.grid.cell = ragged;
    } else {
      // A rough surface (a NeRF extraction's bumps of a few mm) asks for finer cells near it, where
      // torsion's shear is largest: the NeRF T-bar's and cuboid's energies were 1-2.7 % stiff at the
      // exact surfaces' cells and fell about linearly with the cell (surface_roughness.hpp). The
      // bumps add area (NeRF T-bar +8 %), so the cap above would undo the refinement (8.6 mm): a
      // body it did not bind keeps clear of it.
      // The nested level keeps the unrefined grid's coarse cell (19.7 mm on the NeRF T-bar, not
      // 15.8): it only starts the fine Newton, which took 4 iterations from either, and at 15.8 mm
      // its 15 iterations cost 5-11 % of the solve's CPU more (docs/dem_feature_grid.md).
      const RoughSurfaceCell rough = roughSurfaceCell(config, cloud);
      const double refined = rough.asked > 0 && !rough.too_few ? std::max(rough.asked, floor) : config.grid.cell;
      config.grid.nested_ratio *= config.grid.cell / refined;
      config.grid.cell = refined;
      rough_note = roughSurfaceNote(rough, config.grid, cloud.size(), refined, floor);
    }
    coarse_grid = joinedNotes(coarseGridNote(config.grid.cell, floor, volume, area, spacing), rough_note);
  }
  checkGridAgainstParticles(config, spacing);
  return {config, spacing, coarse_grid};
}

}  // namespace demnerf::mechanics
