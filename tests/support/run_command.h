// SPDX-License-Identifier: Apache-2.0
// Runs a command line through the shell and captures what it printed, for the tests that drive
// the real binaries. A command that outlives its time limit is killed and the result says where
// its threads were, so a hang fails the test with evidence instead of running into ctest's
// timeout with no output.
#pragma once

#include <sys/types.h>
#include <string>

#include "absl/time/time.h"

namespace scanprep::testing {

struct CommandResult {
  int exit_code = -1;  // -1 when it did not exit normally
  bool timed_out = false;
  std::string output;  // stdout and stderr; on a timeout followed by the threads' states
};

// `limit` bounds the whole command; the default is well inside ctest's 600 s.
CommandResult RunCommand(const std::string& command_line,
                         absl::Duration limit = absl::Seconds(300));

// Each process in `pid`'s process group and each of its threads: name, state (R running,
// S sleeping, D disk), CPU seconds and the kernel function it waits in, one line per thread.
std::string ThreadStates(pid_t pid);

}  // namespace scanprep::testing
