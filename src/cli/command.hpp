#pragma once
// What every `demnerf` subcommand implements, and how it reports its figures.

#include <nlohmann/json.hpp>
#include <string>

#include "arguments.hpp"

namespace demnerf::cli {

/// Figures a subcommand reports. Printed as "name: value" lines, and with --json the last
/// line of stdout is the whole object.
using Figures = nlohmann::json;

/// A subcommand: its name, one line of purpose, its usage text and the function that runs
/// it. `run` returns the figures; errors are thrown (core::Error -> exit 1, UsageError -> 2).
struct Command {
  const char* name;
  const char* summary;
  const char* usage;
  Figures (*run)(const Arguments& arguments);
};

// One per <name>_command.cpp. Declared here so that every definition, which includes this
// header, has external linkage (a namespace-scope const would otherwise be file-local).
extern const Command kSynthCommand;
extern const Command kTrainCommand;
extern const Command kEvalCommand;
extern const Command kRenderCommand;
extern const Command kExtractCommand;
extern const Command kSampleCommand;
extern const Command kSimulateCommand;
extern const Command kCompareCommand;
extern const Command kPredictCommand;
extern const Command kBagCommand;
extern const Command kInfoCommand;

}  // namespace demnerf::cli
