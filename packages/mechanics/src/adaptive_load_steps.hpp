#pragma once
// The load stepping both network solvers use: the scenario's load is applied in equal steps; a
// step that inverts particles or diverges is undone and halved, and a step that succeeds lets the
// next one grow back towards the nominal size. Private to packages/mechanics/src.

#include <algorithm>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

/// Calls `attempt(target)` for load fractions up to 1; false means the step failed and `undo(done)`
/// must restore the state at fraction `done`. Returns the number of successful steps; throws
/// core::Error naming `solver` and `advice` after more than `max_halvings` halvings.
inline int runAdaptiveLoadSteps(int steps, int max_halvings, const std::function<bool(double)>& attempt,
                                const std::function<void(double)>& undo, const std::string& solver,
                                const std::string& advice, bool verbose) {
  const double nominal = 1.0 / std::max(1, steps);
  double done = 0.0, step = nominal;
  int halvings = 0, taken = 0;
  while (done < 1.0 - 1e-12) {
    const double target = std::min(1.0, done + step);
    if (attempt(target)) {
      done = target;
      ++taken;
      step = std::min(nominal, 2.0 * step);
      continue;
    }
    undo(done);
    step *= 0.5;
    if (++halvings > max_halvings) {
      std::ostringstream msg;
      msg << solver << ": the solve inverted particles (det F <= 0), diverged (NaN) or did not converge at load fraction " << target
          << " even after " << max_halvings << " load-step halvings; the network keeps the state at fraction " << done
          << ". " << advice;
      throw core::Error(msg.str());
    }
    if (verbose) std::cerr << solver << ": retrying with load step " << step << "\n";
  }
  return taken;
}

}  // namespace demnerf::mechanics
