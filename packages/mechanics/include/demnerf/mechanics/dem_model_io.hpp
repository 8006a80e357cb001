#pragma once
// Trained DEM networks on disk: the network, its scales, the scenario and the particles it was
// trained on, in the shared checksummed model container (core/model_container.hpp). A loaded model
// predicts at once, and re-solves warm-started when loads change.

#include <string>

#include "demnerf/mechanics/dem_solver.hpp"

namespace demnerf::mechanics {

constexpr std::uint32_t kDemModelFileVersion = 1;

/// Atomic: a crash or full disk leaves any previous file intact. core::Error on I/O failure.
void saveDemModel(const DemSolver& solver, const std::string& path);
/// core::Error naming the file and the problem (missing, not a DEM model, damaged, other version).
DemSolver loadDemModel(const std::string& path);

}  // namespace demnerf::mechanics
