#pragma once
// Volume weights for particle quadrature of the strain energy.

#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

/// Volume weights that sum to the cloud's volume and give surface particles a share: each
/// surface particle takes A * delta / 2 (delta: depth of its nearest interior particle along the
/// normal) from that interior particle. Without it the energy never sees strain between the
/// first interior layer and the surface, and a network can open a displacement jump there that
/// harvests traction work for free.
std::vector<double> energyWeights(const core::ParticleCloud& cloud);

}  // namespace demnerf::mechanics
