// SPDX-License-Identifier: Apache-2.0
#include "tests/support/run_command.h"

#include <sys/wait.h>

#include <cstdio>

namespace scanprep::testing {

CommandResult RunCommand(const std::string& command_line) {
  CommandResult r;
  FILE* pipe = popen((command_line + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) r.output.append(buffer, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace scanprep::testing
