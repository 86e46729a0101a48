// SPDX-License-Identifier: Apache-2.0
// `scanprep`: command-line client of the scanprep service.
#include <algorithm>
#include <iostream>

#include "client/call_error.h"
#include "client/commands.h"

namespace scanprep::client {

int Fail(const std::string& command, const std::string& message) {
  std::cerr << "scanprep " << command << ": " << message << "\n";
  return kExitFailure;
}

int FailUsage(const std::string& command, const std::string& message) {
  std::cerr << "scanprep " << command << ": " << message << "\n";
  return kExitUsage;
}

int FailFlagFiles(const std::string& command, const absl::Status& status) {
  return status.code() == absl::StatusCode::kInvalidArgument
             ? FailUsage(command, std::string(status.message()))
             : Fail(command, std::string(status.message()));
}

int FailCall(const std::string& command, const std::string& server, const absl::Status& status) {
  std::cerr << "scanprep " << command << ": " << server << ": " << Describe(status) << "\n";
  return ExitCodeFor(status);
}

namespace {

std::vector<Command> Commands() {
  return {ProcessCommand(), HealthCommand(),   InfoCommand(),
          LoadCommand(),    SimulateCommand(), PreviewCommand()};
}

void PrintUsage(std::ostream& out) {
  out << "usage: scanprep COMMAND [args]\n\ncommands:\n";
  for (const Command& c : Commands()) {
    out << "  scanprep " << c.synopsis << "\n      " << c.summary << "\n" << FlagHelp(c.flags);
  }
}

}  // namespace
}  // namespace scanprep::client

int main(int argc, char** argv) {
  using namespace scanprep::client;
  if (argc < 2) {
    PrintUsage(std::cerr);
    return kExitUsage;
  }
  const std::string name = argv[1];
  if (name == "help" || name == "--help" || name == "-h") {
    PrintUsage(std::cout);
    return kExitOk;
  }
  if (name == "--version") {
    std::cout << "scanprep " SCANPREP_VERSION "\n";
    return kExitOk;
  }
  for (const Command& command : Commands()) {
    if (command.name != name) continue;
    const std::vector<std::string> words(argv + 2, argv + argc);
    if (std::find_if(words.begin(), words.end(), [](const std::string& w) {
          return w == "--help" || w == "-h";
        }) != words.end()) {
      std::cout << "usage: scanprep " << command.synopsis << "\n"
                << command.summary << "\n\n"
                << FlagHelp(command.flags);
      return kExitOk;
    }
    auto args = ParseArgs(words, command.flags);
    if (!args.ok()) {
      // The mistake and where the flags are listed, not the whole list: the message is what
      // must be read.
      std::cerr << "scanprep " << name << ": " << args.status().message() << "\nusage: scanprep "
                << command.synopsis << "\n(scanprep " << name << " --help lists its flags)\n";
      return kExitUsage;
    }
    return command.run(*args);
  }
  std::cerr << "scanprep: unknown command '" << name << "'\n";
  PrintUsage(std::cerr);
  return kExitUsage;
}
