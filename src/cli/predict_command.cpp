// `demnerf predict`: displacement and von Mises stress from a saved DEM model (demnerf simulate
// --save-model) at any points and, for a parametric model, any load in its trained range, with
// no training.

#include <chrono>

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/dem_model_io.hpp"

namespace demnerf::cli {
namespace {

Figures runPredict(const Arguments& arguments) {
  arguments.rejectUnknown({"model", "points", "load-scale", "out", "json", "quiet"});
  const mechanics::DemSolver dem = mechanics::loadDemModel(arguments.text("model"));
  const auto [lo, hi] = dem.loadRange();
  const double scale = arguments.number("load-scale", hi >= 1.0 && lo <= 1.0 ? 1.0 : hi);
  const std::vector<Eigen::Vector3d> points =
      arguments.has("points") ? core::readParticles(arguments.text("points")).positions : dem.particles().positions;
  const std::string out_path = arguments.text("out");
  const auto start = std::chrono::steady_clock::now();
  const core::ResultField field = dem.evaluate(points, scale);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  core::writeResult(out_path, field);
  double max_u = 0.0;
  for (const auto& u : field.displacements) max_u = std::max(max_u, u.norm());
  return Figures{{"points", field.size()},  {"load_scale", scale},   {"load_range", {lo, hi}},
                 {"seconds", seconds},      {"max_displacement", max_u}, {"out", out_path}};
}

}  // namespace

const Command kPredictCommand = {
    "predict", "displacement from a saved DEM model, at any points and load in its range",
    "--model M.dem --out R.ply [--points P.ply] [--load-scale S] [--json]", runPredict};

}  // namespace demnerf::cli
