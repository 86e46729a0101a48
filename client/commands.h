// The CLI's subcommands. Adding one = a function with this signature plus a table entry in
// main.cc.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "client/cli_args.h"

namespace scanprep::client {

struct Command {
  std::string name;
  std::string synopsis;  // usage line after "scanprep "
  std::string summary;
  std::vector<FlagSpec> flags;
  // Returns the process exit code.
  std::function<int(const ParsedArgs&)> run;
};

Command ProcessCommand();
Command InfoCommand();
Command LoadCommand();
Command SimulateCommand();

// Prints "scanprep <command>: <message>" and returns exit code 1.
int Fail(const std::string& command, const std::string& message);

}  // namespace scanprep::client
