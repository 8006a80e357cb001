#include "commands.hpp"

namespace demnerf::cli {

const std::vector<Command>& allCommands() {
  static const std::vector<Command> commands = {
      kSynthCommand,    kTrainCommand,  kEvalCommand,    kRenderCommand,  kExtractCommand, kSampleCommand,
      kSimulateCommand, kPredictCommand, kCompareCommand, kBagCommand,     kInfoCommand};
  return commands;
}

}  // namespace demnerf::cli
