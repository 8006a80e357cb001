#pragma once
// dem_node's live settings: a dynamic_reconfigure server (cfg/DemNodeLive.cfg) in the node's
// namespace whose values start as the node's parameters and the scenario's material. A valid
// change is kept and reported through `changed` (the node re-solves its current load); an invalid
// one is refused through `refused` and the client is sent the values in force, so the node never
// solves with them and never stops for them.

#include <dem_nerf/DemNodeLiveConfig.h>
#include <dynamic_reconfigure/server.h>
#include <ros/ros.h>

#include <boost/thread/recursive_mutex.hpp>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "nodes/dem/live_values.hpp"

namespace dem_nerf {

class LiveSettings {
 public:
  /// `changed(what)` is called after a valid change (what: describeChange's text), `refused(why)`
  /// for an invalid one; both on the reconfigure service's thread, with no lock of this class held.
  LiveSettings(const ros::NodeHandle& private_node, const LiveSolveSettings& initial,
               std::function<void(const std::string&)> changed, std::function<void(const std::string&)> refused);
  LiveSettings(const LiveSettings&) = delete;
  LiveSettings& operator=(const LiveSettings&) = delete;

  /// A copy of the settings in force (any thread).
  LiveSolveSettings current() const;

 private:
  void onReconfigure(DemNodeLiveConfig& config, std::uint32_t level);

  mutable std::mutex mutex_;  // guards settings_
  LiveSolveSettings settings_;
  std::function<void(const std::string&)> changed_, refused_;
  boost::recursive_mutex server_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<DemNodeLiveConfig>> server_;  // last: its callback uses the above
};

}  // namespace dem_nerf
