#pragma once
// The PINN's settings checked before anything is built. Private to packages/mechanics/src.

#include "demnerf/mechanics/pinn_solver.hpp"

namespace demnerf::mechanics {

/// core::Error naming the first setting out of range and the range it must lie in.
void checkPinnConfig(const PinnConfig& config);

}  // namespace demnerf::mechanics
