#pragma once
// `demnerf simulate`'s solver settings from its flags (no files read but --config).

#include "arguments.hpp"
#include "demnerf/mechanics/simulate.hpp"

namespace demnerf::cli {

/// Every setting of a run: the DEM method's preset (--method), the file --config over it, then the
/// flags. Throws UsageError naming a bad flag; with no flags it is mechanics::solverDefaults().
mechanics::SimulateOptions simulateSettings(const Arguments& arguments);

}  // namespace demnerf::cli
