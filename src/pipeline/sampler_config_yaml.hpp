#pragma once
// geometry::SamplerConfig from YAML: nerf_node's ~sampling namespace (and any file that wants it).

#include <string>

#include "demnerf/geometry/particle_sampler.hpp"

namespace dem_nerf {

/// The settings in YAML text over `base`; keys: method (random | poisson | grid), spacing (m; 0:
/// 1/40 of the surface's bounding-box diagonal where the caller supports it), seed, weights
/// (voronoi | uniform), surface_volumes. Throws core::Error naming `source` and the key.
demnerf::geometry::SamplerConfig parseSamplerConfig(const std::string& yaml_text, const std::string& source,
                                                    demnerf::geometry::SamplerConfig base = {});

}  // namespace dem_nerf
