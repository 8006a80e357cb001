#include "demnerf/mechanics/solve_control.hpp"

#include <sstream>

namespace demnerf::mechanics {

const char* solveFailureName(SolveFailure failure) {
  switch (failure) {
    case SolveFailure::kTimeLimit: return "time_limit";
    case SolveFailure::kCancelled: return "cancelled";
    case SolveFailure::kNotConverged: return "not_converged";
    case SolveFailure::kInverted: return "inverted";
    case SolveFailure::kDegenerate: return "degenerate";
  }
  return "unknown";
}

SolveClock::SolveClock(const SolveControl& control, std::string solver)
    : SolveClock(control, std::move(solver), std::chrono::steady_clock::now()) {}

SolveClock::SolveClock(const SolveControl& control, std::string solver, std::chrono::steady_clock::time_point start)
    : control_(control), solver_(std::move(solver)), start_(start), last_report_(start) {}

double SolveClock::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void SolveClock::report(SolveProgress progress, bool force) {
  if (!control_.progress) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && reported_ && std::chrono::duration<double>(now - last_report_).count() < control_.progress_interval)
    return;
  if (!force && !reported_ && std::chrono::duration<double>(now - start_).count() < control_.progress_interval)
    return;
  reported_ = true;
  last_report_ = now;
  progress.solver = solver_;
  progress.elapsed = std::chrono::duration<double>(now - start_).count();
  control_.progress(progress);
}

void SolveClock::check(const std::string& state) const {
  if (control_.cancel && control_.cancel->load())
    throw SolveError(SolveFailure::kCancelled, solver_ + ": cancelled after " + std::to_string(elapsed()) +
                                                   " s; kept " + state);
  if (control_.time_limit > 0 && elapsed() > control_.time_limit) {
    std::ostringstream msg;
    msg << solver_ << ": no equilibrium within the time limit of " << control_.time_limit << " s; kept " << state
        << ". Raise the limit (--time-limit, ~solve_time_limit), or make the problem cheaper (coarser particles, a "
           "coarser grid or mesh, a smaller load)";
    throw SolveError(SolveFailure::kTimeLimit, msg.str());
  }
}

}  // namespace demnerf::mechanics
