#pragma once
// Displacement error of one result field against a reference on the same particles.

#include <cstddef>

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

struct ResultComparison {
  double rel_l2 = 0.0;          ///< ||u - u_ref|| / ||u_ref|| over all rows
  double max_error = 0.0;       ///< largest |u_i - u_ref,i| (m)
  double max_position_gap = 0.0;  ///< largest |X_i - X_ref,i| (m)
  std::size_t rows = 0;
};

/// Row-by-row comparison. Throws core::Error when the row counts differ, when a rest position
/// differs by more than `position_tolerance` times the reference's bounding-box diagonal (the
/// files are not on the same particles, or not in the same order), or when the reference
/// displacement is zero everywhere (no relative error exists).
ResultComparison compareResults(const core::ResultField& result, const core::ResultField& reference,
                                double position_tolerance = 1e-6);

}  // namespace demnerf::mechanics
