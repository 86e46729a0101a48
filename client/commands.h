// SPDX-License-Identifier: Apache-2.0
// The CLI's subcommands. Adding one = a function with this signature plus a table entry in
// main.cc.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
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
Command PreviewCommand();
Command HealthCommand();

// Prints "scanprep <command>: <message>" and returns exit code 1.
int Fail(const std::string& command, const std::string& message);

// Prints "scanprep <command>: <message>" and returns exit code 2 (a bad command line).
int FailUsage(const std::string& command, const std::string& message);

// A flag whose check reads a file (--tls_ca, --tls_cert, --tls_key): INVALID_ARGUMENT (flags that
// do not go together, a directory for a file) is a bad command line, exit 2; a file that cannot
// be read, 1.
int FailFlagFiles(const std::string& command, const absl::Status& status);

// A failed call to `server`: prints "scanprep <command>: <server>: " and the status with its
// error details, and returns the exit code that tells a script what to do (call_error.h).
int FailCall(const std::string& command, const std::string& server, const absl::Status& status);

}  // namespace scanprep::client
