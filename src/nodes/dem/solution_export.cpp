#include "nodes/dem/solution_export.hpp"

#include <cstdio>
#include <exception>
#include <filesystem>
#include <system_error>

#include "demnerf/vtk_export/vtu_writer.hpp"

namespace dem_nerf {

std::string SolutionExport::nextPath() const {
  char name[40];
  // Zero-padded so that a listing sorts in solve order; ParaView opens the series as one.
  std::snprintf(name, sizeof name, "solve_%04llu.vtu", static_cast<unsigned long long>(written_ + 1));
  return (std::filesystem::path(folder_) / name).string();
}

SolutionExport::Report SolutionExport::write(const demnerf::core::ParticleCloud& cloud,
                                             const demnerf::mechanics::SimulationOutcome& outcome) {
  Report report;
  if (!enabled()) return report;
  const std::string path = nextPath();
  try {
    std::error_code ec;
    std::filesystem::create_directories(folder_, ec);
    if (ec) {
      report.error = "~export_dir " + folder_ + " could not be created (" + ec.message() + "): solution not exported";
      return report;
    }
    // The particles, whatever the solver: the node keeps no FEM mesh between solves.
    demnerf::vtk_export::writeParticlesVtu(path, cloud, outcome.field);
    ++written_;
    report.note = ", written " + path;
  } catch (const std::exception& error) {
    report.error = std::string("solution not exported: ") + error.what();
  } catch (...) {
    report.error = "solution not exported: unknown error writing " + path;
  }
  return report;
}

}  // namespace dem_nerf
