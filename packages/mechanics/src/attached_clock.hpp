#pragma once
// The FEM's and the PINN's solve(SolveClock&): the solver reads its budget, progress and cancel
// through a clock pointer that must not outlive the call (the clock is the caller's), also when
// the solve throws.

#include "demnerf/mechanics/solve_control.hpp"

namespace demnerf::mechanics {

/// Points `slot` at `clock` for this object's lifetime, then back at nothing.
class AttachedClock {
 public:
  AttachedClock(SolveClock*& slot, SolveClock& clock) : slot_(slot) { slot_ = &clock; }
  ~AttachedClock() { slot_ = nullptr; }
  AttachedClock(const AttachedClock&) = delete;
  AttachedClock& operator=(const AttachedClock&) = delete;

 private:
  SolveClock*& slot_;
};

}  // namespace demnerf::mechanics
