#pragma once
// dem_node's ~export_dir: every successful solve written as <export_dir>/solve_<n>.vtu for
// ParaView (packages/vtk_export). No ROS here: the node calls it after each solve and puts what it
// says on ~status.

#include <cstdint>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/simulate.hpp"

namespace dem_nerf {

class SolutionExport {
 public:
  /// What one write did: `note` for the solve's status line (", written PATH"), or `error` (the
  /// file was not written and why); both empty when exporting is off.
  struct Report {
    std::string note;
    std::string error;
  };

  /// An empty folder turns exporting off. The folder is created at the first write.
  explicit SolutionExport(std::string folder) : folder_(std::move(folder)) {}
  bool enabled() const { return !folder_.empty(); }

  /// Writes the particles with the outcome's fields as the next solve_<n>.vtu (n counts the
  /// files written, from 1: a failed write leaves no gap). Never throws: a full disk or a bad
  /// folder must not take the solve's answer down with it.
  Report write(const demnerf::core::ParticleCloud& cloud, const demnerf::mechanics::SimulationOutcome& outcome);

  /// The file the next write goes to.
  std::string nextPath() const;

 private:
  std::string folder_;
  std::uint64_t written_ = 0;
};

}  // namespace dem_nerf
