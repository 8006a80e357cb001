#pragma once
// The surface flags `demnerf extract` and `demnerf sample --model` share, as the one
// dem_nerf::SurfaceConfig nerf_node's ~extraction also fills.

#include <string>
#include <set>

#include "arguments.hpp"
#include "pipeline/surface_config.hpp"

namespace demnerf::cli {

/// The flags' names, for Arguments::rejectUnknown.
std::set<std::string> surfaceFlagNames();

/// --resolution, --surface, --opacity, --threshold, --max-faces, --smooth, --box,
/// --max-second-piece, --solid-radius, --solid-behind, --solid-cameras (loads the dataset's
/// training cameras; needs --solid-radius) and --solid-views (SurfaceConfig::solid_views, 1 with
/// --solid-cameras alone) over SurfaceConfig's defaults; UsageError naming the flag when one is bad.
/// --threshold alone means a density surface (its meaning before opacity surfaces existed).
dem_nerf::SurfaceConfig surfaceFlags(const Arguments& arguments);

/// The flags with their defaults, for the usage texts.
std::string surfaceFlagsUsage();

}  // namespace demnerf::cli
