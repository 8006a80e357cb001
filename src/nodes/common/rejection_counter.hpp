#pragma once
// Counts refused inputs by cause, so that nothing a node drops goes unseen: every refusal is
// counted (published as numeric fields on ~status) and logged, once per cause per interval with
// the number of refusals the log left out, instead of a global throttle that hides whole causes.

#include <dem_nerf/RejectionCount.h>

#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace dem_nerf {

class RejectionCounter {
 public:
  /// `node` prefixes the log lines; a cause logs at most once per `log_interval`.
  explicit RejectionCounter(std::string node, std::chrono::steady_clock::duration log_interval = std::chrono::seconds(5));

  /// Counts one refusal of `cause` (a short fixed key) and logs `message` unless this cause
  /// logged within the interval. Thread-safe.
  void count(const std::string& cause, const std::string& message);
  std::uint32_t total() const;
  std::uint32_t of(const std::string& cause) const;
  /// Every cause seen so far, sorted by name.
  std::vector<dem_nerf::RejectionCount> counts() const;

 private:
  struct Entry {
    std::uint32_t count = 0;
    std::uint32_t unlogged = 0;  ///< refusals since this cause last logged
    std::string last_message;
    std::chrono::steady_clock::time_point last_log;
    bool logged = false;
  };
  std::string node_;
  std::chrono::steady_clock::duration log_interval_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

}  // namespace dem_nerf
