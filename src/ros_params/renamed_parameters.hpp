#pragma once
// Parameters that moved into an algorithm's namespace: a launch file that still sets the old name
// is refused with the new one, rather than silently running on the default.

#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

/// Throws core::Error for the first old name (first) that is set, naming its replacement (second).
template <class Node>
void rejectRenamed(const Node& node, const std::vector<std::pair<std::string, std::string>>& renamed) {
  for (const auto& [old_name, new_name] : renamed) {
    if (node.hasParam(old_name))
      throw demnerf::core::Error("parameter ~" + old_name + " is now " + new_name +
                                 " (one namespace per algorithm; see the README's ROS interface)");
  }
}

}  // namespace dem_nerf
