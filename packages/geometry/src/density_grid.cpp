#include "demnerf/geometry/density_grid.hpp"

#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {

void DensityGrid::validate(const std::string& what) const {
  std::ostringstream problem;
  if ((dims.array() < 2).any()) {
    problem << what << ": dims (" << dims.transpose() << ") must be at least 2 on every axis";
  } else if (!spacing.allFinite() || (spacing.array() <= 0).any()) {
    problem << what << ": spacing (" << spacing.transpose() << ") must be positive";
  } else if (!origin.allFinite()) {
    problem << what << ": origin is NaN or Inf";
  } else if (values.size() != static_cast<std::size_t>(dims.x()) * dims.y() * dims.z()) {
    problem << what << ": " << values.size() << " values for dims (" << dims.transpose() << ") = "
            << static_cast<std::size_t>(dims.x()) * dims.y() * dims.z() << " nodes";
  } else {
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (std::isnan(values[i])) {
        problem << what << ": value " << i << " is NaN";
        break;
      }
    }
  }
  if (!problem.str().empty()) throw core::Error(problem.str());
}

double densityForOpacity(double alpha, double step) {
  if (!(alpha > 0 && alpha < 1) || !(step > 0)) {
    std::ostringstream message;
    message << "densityForOpacity: alpha " << alpha << " must be in (0, 1) and step " << step << " positive";
    throw core::Error(message.str());
  }
  return -std::log(1.0 - alpha) / step;
}

}  // namespace demnerf::geometry
