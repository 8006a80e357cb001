// `demnerf simulate`'s flags as solver settings: the DEM method's preset, then --config FILE, then
// the flags, by the library's rules (mechanics::normalised), as dem_node reads its parameters.

#include "simulate_settings.hpp"

#include <cstdlib>
#include <optional>
#include <string>
#include <utility>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/solver_config_yaml.hpp"

namespace demnerf::cli {
namespace {

/// --load-range MIN,MAX as two numbers.
std::pair<double, double> loadRange(const std::string& range) {
  const auto comma = range.find(',');
  char* end = nullptr;
  const double lo = std::strtod(range.c_str(), &end);
  const double hi = comma == std::string::npos ? 0.0 : std::strtod(range.c_str() + comma + 1, nullptr);
  if (comma == std::string::npos || end != range.c_str() + comma || !(lo < hi))
    throw UsageError("option --load-range expects MIN,MAX load fractions with MIN < MAX (e.g. 0,1.5), got '" + range + "'");
  return {lo, hi};
}

/// A length flag that must be > 0 when given.
std::optional<double> positiveFlag(const Arguments& arguments, const char* name, const char* meaning) {
  if (!arguments.has(name)) return std::nullopt;
  const double value = arguments.number(name);
  if (!(value > 0)) throw UsageError(std::string("option --") + name + " expects " + meaning);
  return value;
}

/// The DEM settings of the flags over `dem` (the method's preset with the config file over it),
/// by the library's rules (mechanics::normalised), whose refusals are usage errors here.
void applyDemFlags(const Arguments& arguments, mechanics::DemConfig& dem) {
  dem.network.width = arguments.integer("width", dem.network.width);
  dem.network.depth = arguments.integer("depth", dem.network.depth);
  dem.threads = arguments.integer("threads", dem.threads);
  if (arguments.flag("newton")) dem.output_newton.enabled = true;
  mechanics::DemChoice choice;
  if (arguments.has("iterations")) choice.adam_iterations = arguments.integer("iterations", dem.adam.iterations);
  choice.grid_cell =
      positiveFlag(arguments, "grid-cell", "the feature grid's cell edge in metres (> 0; about two particle spacings)");
  choice.grid_spacings = positiveFlag(arguments, "grid-spacings",
                                      "the feature grid's cell in particle spacings (> 0; 2 is a good choice)");
  choice.grid_body_cells = positiveFlag(arguments, "grid-body-cells",
                                        "how many grid cells the body's volume holds (> 0; 2000 gives the T-bar's 60 mm section six 10 mm cells)");
  if (arguments.has("boundary")) {
    const std::string boundary = arguments.text("boundary");
    if (boundary == "penalty") dem.boundary.kind = mechanics::DemConfig::Boundary::kPenalty;
    else if (boundary == "exact") dem.boundary.kind = mechanics::DemConfig::Boundary::kExact;
    else throw UsageError("option --boundary expects exact or penalty, got '" + boundary + "'");
  }
  if (arguments.has("load-range")) choice.load_range = loadRange(arguments.text("load-range"));
  try {
    dem = mechanics::normalised(dem, choice);
  } catch (const core::Error& error) {
    throw UsageError(error.what());
  }
}

}  // namespace

mechanics::SimulateOptions simulateSettings(const Arguments& arguments) {
  const std::string method = arguments.text("method", "grid");
  if (method != "grid" && method != "mlp") throw UsageError("option --method expects grid or mlp, got '" + method + "'");
  mechanics::SimulateOptions options = mechanics::solverDefaults(method, arguments.text("config", ""));
  applyDemFlags(arguments, options.dem);
  // The PINN takes the same network, iteration and thread flags (its own defaults when absent).
  options.pinn.adam_iterations = arguments.integer("iterations", options.pinn.adam_iterations);
  options.pinn.width = arguments.integer("width", options.pinn.width);
  options.pinn.depth = arguments.integer("depth", options.pinn.depth);
  options.pinn.threads = arguments.integer("threads", options.pinn.threads);
  options.voxel.cell = arguments.number("cell", options.voxel.cell);
  options.voxel.order = arguments.integer("order", options.voxel.order);
  if (options.voxel.order != 1 && options.voxel.order != 2)
    throw UsageError("option --order expects 1 (TET4) or 2 (TET10), got " + std::to_string(options.voxel.order));
  if (options.voxel.cell < 0) throw UsageError("option --cell expects a positive length in metres (0: automatic)");
  // How --mesh is meshed for the FEM: CGAL tetrahedra that follow the surface, or voxels.
  if (arguments.has("mesher")) {
    const std::string mesher = arguments.text("mesher");
    if (mesher == "voxel") options.mesher = mechanics::SimulateOptions::Mesher::kVoxel;
    else if (mesher == "cgal") options.mesher = mechanics::SimulateOptions::Mesher::kCgal;
    else throw UsageError("option --mesher expects cgal or voxel, got '" + mesher + "'");
  }
  options.control.time_limit = arguments.number("time-limit", options.control.time_limit);
  if (options.control.time_limit < 0)
    throw UsageError("option --time-limit expects seconds >= 0 (0: no limit), got " + arguments.text("time-limit"));
  return options;
}


}  // namespace demnerf::cli
