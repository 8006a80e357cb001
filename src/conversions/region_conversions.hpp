#pragma once
// dem_nerf Region/Fixture/Load messages <-> core scenario types.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>

#include "demnerf/core/scenario.hpp"

namespace dem_nerf {

/// Throws demnerf::core::Error for an unknown type, NaN/Inf or a non-positive size.
demnerf::core::Region fromMessage(const dem_nerf::Region& message);
demnerf::core::Fixture fromMessage(const dem_nerf::Fixture& message);
demnerf::core::Load fromMessage(const dem_nerf::Load& message);

dem_nerf::Region toMessage(const demnerf::core::Region& region);

}  // namespace dem_nerf
