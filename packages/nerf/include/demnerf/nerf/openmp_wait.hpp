#pragma once
// How the training's OpenMP threads wait between parallel regions.
//
// libgomp's default lets a thread that finished its share spin (up to GOMP_SPINCOUNT = 300,000
// pauses, ~10-20 ms here) before it sleeps. A NeRF step opens a few short parallel regions with
// serial work between them, so on a 2-core machine shared with other jobs the spinning thread
// burns cycles that would otherwise run the descheduled one: on the fox at load ~12, 120 CPU s of
// training made 2403 steps spinning and 3117 sleeping (docs/nerf_real_captures.md, "eighth step").
// libgomp reads OMP_WAIT_POLICY once, in its load-time constructor, so setting it from main is too
// late; the entry points that train re-execute themselves with it set instead.

namespace demnerf::nerf {

/// When neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT is set, sets OMP_WAIT_POLICY=passive and
/// replaces the process with `exe` (default: this executable) run with the same argv, so that
/// libgomp starts with sleeping waits. Call first thing in main, before any thread exists.
/// Returns when a policy is already set (the caller's choice is kept, and the re-executed
/// process sees its own setting) or when the exec fails (the process goes on spinning).
void reexecWithPassiveOpenMpWait(char** argv, const char* exe = "/proc/self/exe");

}  // namespace demnerf::nerf
