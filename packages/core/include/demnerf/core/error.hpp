#pragma once
// The one exception type every dem_nerf library throws at its API boundary.

#include <stdexcept>
#include <string>

namespace demnerf::core {

/// An error a user can act on: the message names what was wrong and where.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace demnerf::core
