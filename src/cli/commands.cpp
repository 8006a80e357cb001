#include "commands.hpp"

namespace demnerf::cli {

// Defined in the <name>_command.cpp files.
extern const Command kSynthCommand;
extern const Command kTrainCommand;
extern const Command kEvalCommand;
extern const Command kRenderCommand;
extern const Command kExtractCommand;
extern const Command kSampleCommand;
extern const Command kSimulateCommand;
extern const Command kCompareCommand;
extern const Command kPipelineCommand;
extern const Command kBagCommand;
extern const Command kInfoCommand;

const std::vector<Command>& allCommands() {
  static const std::vector<Command> commands = {
      kSynthCommand,   kTrainCommand,    kEvalCommand,    kRenderCommand,
      kExtractCommand, kSampleCommand,   kSimulateCommand, kCompareCommand,
      kPipelineCommand, kBagCommand,     kInfoCommand};
  return commands;
}

}  // namespace demnerf::cli
