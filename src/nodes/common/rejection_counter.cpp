#include "nodes/common/rejection_counter.hpp"

#include <ros/console.h>

#include <algorithm>
#include <limits>

namespace dem_nerf {

RejectionCounter::RejectionCounter(std::string node, std::chrono::steady_clock::duration log_interval)
    : node_(std::move(node)), log_interval_(log_interval) {}

void RejectionCounter::count(const std::string& cause, const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  std::uint32_t left_out = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Entry& entry = entries_[cause];
    if (entry.count < std::numeric_limits<std::uint32_t>::max()) ++entry.count;
    entry.last_message = message;
    if (entry.logged && now - entry.last_log < log_interval_) {
      ++entry.unlogged;
      return;
    }
    left_out = entry.unlogged;
    entry.unlogged = 0;
    entry.last_log = now;
    entry.logged = true;
  }
  if (left_out > 0) {
    ROS_WARN("%s: %s (and %u more '%s' refusals since the last line)", node_.c_str(), message.c_str(), left_out,
             cause.c_str());
  } else {
    ROS_WARN("%s: %s", node_.c_str(), message.c_str());
  }
}

std::uint32_t RejectionCounter::total() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::uint64_t sum = 0;
  for (const auto& [cause, entry] : entries_) sum += entry.count;
  return static_cast<std::uint32_t>(std::min<std::uint64_t>(sum, std::numeric_limits<std::uint32_t>::max()));
}

std::uint32_t RejectionCounter::of(const std::string& cause) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = entries_.find(cause);
  return it == entries_.end() ? 0 : it->second.count;
}

std::vector<dem_nerf::RejectionCount> RejectionCounter::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<dem_nerf::RejectionCount> out;
  for (const auto& [cause, entry] : entries_) {
    dem_nerf::RejectionCount item;
    item.cause = cause;
    item.count = entry.count;
    item.last_message = entry.last_message;
    out.push_back(item);
  }
  return out;
}

}  // namespace dem_nerf
