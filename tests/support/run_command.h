// SPDX-License-Identifier: Apache-2.0
// Runs a command line through the shell and captures what it printed, for the tests that drive
// the real binaries.
#pragma once

#include <string>

namespace scanprep::testing {

struct CommandResult {
  int exit_code = -1;  // -1 when it did not exit normally
  std::string output;  // stdout and stderr
};

CommandResult RunCommand(const std::string& command_line);

}  // namespace scanprep::testing
