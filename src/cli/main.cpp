// demnerf: one executable, one subcommand per pipeline stage (see `demnerf --help`).

#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "demnerf/core/error.hpp"
#include "runtime/configure_runtime.hpp"

namespace {

using demnerf::cli::Arguments;
using demnerf::cli::Command;
using demnerf::cli::Figures;

// Options that take no value (any other --name takes the next token as its value).
const std::set<std::string> kFlags = {"json", "help", "once", "quiet", "newton", "print-config"};

void printOverview(std::ostream& out) {
  out << "usage: demnerf <command> [options]   (demnerf <command> --help for its options)\n\n"
         "commands:\n";
  for (const Command& command : demnerf::cli::allCommands()) {
    out << "  " << command.name << std::string(10 - std::string(command.name).size(), ' ')
        << command.summary << "\n";
  }
  out << "\n--json makes the last line of stdout one JSON object with the command's figures.\n";
}

void printFigures(const Figures& figures, bool json) {
  for (const auto& item : figures.items()) {
    std::cout << item.key() << ": " << item.value().dump() << "\n";
  }
  if (json) std::cout << figures.dump() << std::endl;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> tokens(argv + 1, argv + argc);
  if (tokens.empty() || tokens[0] == "--help" || tokens[0] == "-h" || tokens[0] == "help") {
    printOverview(std::cout);
    return tokens.empty() ? 2 : 0;
  }
  const std::string name = tokens[0];
  const Command* command = nullptr;
  for (const Command& candidate : demnerf::cli::allCommands()) {
    if (name == candidate.name) command = &candidate;
  }
  if (command == nullptr) {
    std::cerr << "demnerf: unknown command '" << name << "'\n";
    printOverview(std::cerr);
    return 2;
  }
  tokens.erase(tokens.begin());
  try {
    const Arguments arguments(tokens, kFlags);
    if (arguments.flag("help")) {
      std::cout << "usage: demnerf " << command->name << " " << command->usage << "\n";
      return 0;
    }
    // --threads where a command takes it (0: all cores); simulate and train refine it from their configs.
    // One command at a time on this thread: OpenBLAS's idle workers may be ended (park_blas_threads).
    dem_nerf::configureRuntime({arguments.integer("threads", 0), false, true});
    const Figures figures = command->run(arguments);
    printFigures(figures, arguments.flag("json"));
    return 0;
  } catch (const demnerf::cli::UsageError& error) {
    std::cerr << "demnerf " << name << ": " << error.what() << "\n"
              << "usage: demnerf " << command->name << " " << command->usage << "\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "demnerf " << name << ": " << error.what() << "\n";
    return 1;
  }
}
