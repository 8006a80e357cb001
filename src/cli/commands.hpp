#pragma once
// The table of `demnerf` subcommands. Each lives in its own <name>_command.cpp.

#include <vector>

#include "command.hpp"

namespace demnerf::cli {

/// Every subcommand, in the order `demnerf --help` lists them.
const std::vector<Command>& allCommands();

/// Thrown by a subcommand whose stage is not built yet: exit code 2 with this message.
class NotBuiltYet : public std::runtime_error {
 public:
  explicit NotBuiltYet(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace demnerf::cli
