#include "demnerf/mechanics/compare_results.hpp"

#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

ResultComparison compareResults(const core::ResultField& result, const core::ResultField& reference,
                                double position_tolerance) {
  result.validate();
  reference.validate();
  if (result.size() != reference.size()) {
    std::ostringstream msg;
    msg << "the result has " << result.size() << " rows but the reference has " << reference.size()
        << ": compare results computed on the same particle file";
    throw core::Error(msg.str());
  }
  if (reference.size() == 0) throw core::Error("the reference result has no rows");
  Eigen::Vector3d lo = reference.positions[0], hi = lo;
  for (const auto& p : reference.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double allowed = position_tolerance * std::max((hi - lo).norm(), 1e-300);
  ResultComparison c;
  c.rows = result.size();
  double err2 = 0.0, ref2 = 0.0;
  for (std::size_t i = 0; i < result.size(); ++i) {
    const double gap = (result.positions[i] - reference.positions[i]).norm();
    c.max_position_gap = std::max(c.max_position_gap, gap);
    if (gap > allowed) {
      std::ostringstream msg;
      msg << "row " << i << ": rest position (" << result.positions[i].transpose() << ") differs from the reference's ("
          << reference.positions[i].transpose() << ") by " << gap << " m (allowed " << allowed
          << " m): the files are not on the same particles in the same order";
      throw core::Error(msg.str());
    }
    const double e = (result.displacements[i] - reference.displacements[i]).norm();
    c.max_error = std::max(c.max_error, e);
    err2 += e * e;
    ref2 += reference.displacements[i].squaredNorm();
  }
  if (!(ref2 > 0.0)) throw core::Error("the reference displacement is zero everywhere: no relative error exists");
  c.rel_l2 = std::sqrt(err2 / ref2);
  return c;
}

}  // namespace demnerf::mechanics
