#pragma once
// Selecting particles by region, for fixtures and loads.

#include <cstddef>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::geometry {

enum class ParticleKind { kAll, kSurface, kInterior };

/// Indices (ascending) of the particles of `kind` inside `region`. Throws core::Error when none
/// is selected or the region holds NaN/Inf; `what` names the user of the region in the message,
/// e.g. "fixture 'base'" -> "fixture 'base' selects no surface particles: region box center ...".
std::vector<std::size_t> selectParticles(const core::ParticleCloud& cloud, const core::Region& region,
                                         const std::string& what, ParticleKind kind = ParticleKind::kAll);

}  // namespace demnerf::geometry
