#pragma once
// The table of `demnerf` subcommands. Each lives in its own <name>_command.cpp.

#include <vector>

#include "command.hpp"

namespace demnerf::cli {

/// Every subcommand, in the order `demnerf --help` lists them.
const std::vector<Command>& allCommands();

}  // namespace demnerf::cli
