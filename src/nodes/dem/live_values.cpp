#include "nodes/dem/live_values.hpp"

#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace dem_nerf {
namespace {

using demnerf::core::Error;

template <class T>
void noteChange(std::ostringstream& text, const char* name, const T& before, const T& after) {
  if (before == after) return;
  if (text.tellp() > 0) text << ", ";
  text << name << " " << before << " -> " << after;
}

void requireFinite(double value, const char* name) {
  if (!std::isfinite(value)) throw Error(std::string(name) + " must be a finite number");
}

}  // namespace

bool LiveValues::operator==(const LiveValues& other) const {
  return youngs_modulus == other.youngs_modulus && poisson_ratio == other.poisson_ratio && solver == other.solver &&
         dem_grid_spacings == other.dem_grid_spacings && fem_order == other.fem_order &&
         solve_time_limit == other.solve_time_limit && load_scale == other.load_scale;
}

void LiveSolveSettings::applyTo(demnerf::core::Scenario& scenario, bool scale_loads) const {
  scenario.material.youngs_modulus = youngs_modulus;
  scenario.material.poisson_ratio = poisson_ratio;
  if (!scale_loads || load_scale == 1.0) return;
  // The whole load case scales, as the parametric DEM's load fraction does, so that a scale
  // inside its trained range is answered without training.
  for (auto& load : scenario.loads) {
    load.force *= load_scale;
    load.torque *= load_scale;
  }
  for (auto& fixture : scenario.fixtures) fixture.displacement *= load_scale;
  scenario.body_force *= load_scale;
}

LiveSolveSettings initialLiveSettings(demnerf::mechanics::SolverChoice solver,
                                      const demnerf::mechanics::SimulateOptions& options,
                                      const demnerf::core::Material& material) {
  LiveSolveSettings settings;
  settings.solver = solver;
  settings.options = options;
  settings.youngs_modulus = material.youngs_modulus;
  settings.poisson_ratio = material.poisson_ratio;
  return settings;
}

LiveValues liveValuesOf(const LiveSolveSettings& settings) {
  LiveValues values;
  values.youngs_modulus = settings.youngs_modulus;
  values.poisson_ratio = settings.poisson_ratio;
  values.solver = demnerf::mechanics::solverName(settings.solver);
  values.dem_grid_spacings = settings.options.dem.grid.spacings;
  values.fem_order = settings.options.voxel.order;
  values.solve_time_limit = settings.options.control.time_limit;
  values.load_scale = settings.load_scale;
  return values;
}

LiveSolveSettings withLiveValues(const LiveSolveSettings& current, const LiveValues& values) {
  requireFinite(values.youngs_modulus, "youngs_modulus");
  requireFinite(values.poisson_ratio, "poisson_ratio");
  requireFinite(values.dem_grid_spacings, "dem_grid_spacings");
  requireFinite(values.solve_time_limit, "solve_time_limit");
  requireFinite(values.load_scale, "load_scale");
  if (!(values.youngs_modulus > 0.0)) throw Error("youngs_modulus must be > 0 Pa");
  if (values.poisson_ratio < 0.0 || values.poisson_ratio >= 0.5)
    throw Error("poisson_ratio must lie in [0, 0.5): 0.5 is incompressible, which the Neo-Hookean model cannot take");
  if (values.dem_grid_spacings < 0.0)
    throw Error("dem_grid_spacings must be >= 0 (0: the grid sized from the body, the default)");
  if (values.fem_order != 1 && values.fem_order != 2) throw Error("fem_order must be 1 or 2");
  if (values.solve_time_limit < 0.0) throw Error("solve_time_limit must be >= 0 s (0: no limit)");
  LiveSolveSettings next = current;
  next.solver = demnerf::mechanics::parseSolverChoice(values.solver);  // names the bad value
  next.youngs_modulus = values.youngs_modulus;
  next.poisson_ratio = values.poisson_ratio;
  next.load_scale = values.load_scale;
  next.options.voxel.order = values.fem_order;
  next.options.control.time_limit = values.solve_time_limit;
  const LiveValues before = liveValuesOf(current);
  if (values.dem_grid_spacings != before.dem_grid_spacings) {
    if (current.options.dem.parametric.enabled)
      throw Error("dem_grid_spacings does not apply with ~dem/parametric/enabled: the parametric DEM is the MLP alone");
    // Spacings rule once set here: a grid given by ~dem/grid/cell or ~dem/grid/body_cells yields.
    // 0 goes back to the default grid, sized from the body (the MLP alone is ~dem_method mlp).
    next.options.dem.grid.spacings = values.dem_grid_spacings;
    next.options.dem.grid.cell = 0.0;
    next.options.dem.grid.body_cells =
        values.dem_grid_spacings > 0 ? 0.0 : demnerf::mechanics::DemConfig{}.grid.body_cells;
  }
  if (values.youngs_modulus != before.youngs_modulus || values.poisson_ratio != before.poisson_ratio ||
      next.options.dem.grid.spacings != current.options.dem.grid.spacings)
    ++next.model_generation;
  return next;
}

std::string describeChange(const LiveValues& before, const LiveValues& after) {
  std::ostringstream text;
  text.precision(4);
  noteChange(text, "youngs_modulus", before.youngs_modulus, after.youngs_modulus);
  noteChange(text, "poisson_ratio", before.poisson_ratio, after.poisson_ratio);
  noteChange(text, "solver", before.solver, after.solver);
  noteChange(text, "dem_grid_spacings", before.dem_grid_spacings, after.dem_grid_spacings);
  noteChange(text, "fem_order", before.fem_order, after.fem_order);
  noteChange(text, "solve_time_limit", before.solve_time_limit, after.solve_time_limit);
  noteChange(text, "load_scale", before.load_scale, after.load_scale);
  return text.tellp() > 0 ? text.str() : std::string("nothing changed");
}

}  // namespace dem_nerf
