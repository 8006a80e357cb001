#pragma once
// What every solver (DEM, FEM, PINN) takes from its caller besides the problem: a time budget,
// a progress sink and a cancel flag; and the one error type a solve that did not reach an
// equilibrium throws, with its cause, so a node can count and report failures by cause.

#include <atomic>
#include <chrono>
#include <functional>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

/// One progress report of a running solve (the CLI prints it, dem_node publishes it on ~status).
struct SolveProgress {
  std::string solver;          ///< "dem", "fem" or "pinn"
  std::string phase;           ///< what runs now: "newton", "adam", "lbfgs", "mesh", ...
  double load_fraction = 0.0;  ///< the load step being solved, in (0, 1]
  int iteration = 0;           ///< iterations so far, over all load steps
  double energy = 0.0;         ///< potential energy of the current state (J)
  double residual = 0.0;       ///< |discrete weak-form residual| / |external load| (NaN: not known yet)
  double elapsed = 0.0;        ///< seconds since the solve started
};

/// A solve's budget and listeners. Copyable; the cancel flag is owned by the caller.
struct SolveControl {
  /// Wall-clock budget of one solve in seconds (0: none). A solve past it stops at the next check,
  /// keeps its last good state and throws SolveError{kTimeLimit}.
  double time_limit = 60.0;
  /// Called at most once per progress_interval seconds while the solve runs (and not at all when
  /// empty), from the solving thread.
  std::function<void(const SolveProgress&)> progress;
  double progress_interval = 1.0;
  /// Set from another thread to stop the solve at its next check (SolveError{kCancelled}).
  const std::atomic<bool>* cancel = nullptr;
};

/// Why a solve did not return an equilibrium.
enum class SolveFailure {
  kTimeLimit,     ///< SolveControl::time_limit ran out
  kCancelled,     ///< SolveControl::cancel was set
  kNotConverged,  ///< the iterations ran out, or the equilibrium check failed
  kInverted,      ///< every load step tried inverted the material (det F <= 0) or turned NaN
  kDegenerate,    ///< the set-up cannot have a unique equilibrium (nothing or everything fixed, ...)
};

const char* solveFailureName(SolveFailure failure);

/// A solve that failed; what() names the cause, the state kept and what to change.
class SolveError : public core::Error {
 public:
  SolveError(SolveFailure failure, const std::string& message) : core::Error(message), failure_(failure) {}
  SolveFailure failure() const { return failure_; }

 private:
  SolveFailure failure_;
};

/// The running side of a SolveControl: elapsed time, throttled progress and the stop checks.
class SolveClock {
 public:
  SolveClock(const SolveControl& control, std::string solver);
  /// A clock whose budget started at `start` (a solver's construction: its set-up counts).
  SolveClock(const SolveControl& control, std::string solver, std::chrono::steady_clock::time_point start);
  double elapsed() const;
  /// Forwards to control.progress when progress_interval has passed since the last report (or
  /// `force`); fills solver and elapsed.
  void report(SolveProgress progress, bool force = false);
  /// Throws SolveError (kCancelled or kTimeLimit) when the caller cancelled or the budget is spent.
  /// `state` says what the solver keeps ("the state at load fraction 0.5").
  void check(const std::string& state) const;

 private:
  SolveControl control_;
  std::string solver_;
  std::chrono::steady_clock::time_point start_, last_report_;
  bool reported_ = false;
};

}  // namespace demnerf::mechanics
