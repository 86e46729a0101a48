// SPDX-License-Identifier: Apache-2.0
#include "tests/support/run_command.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"

namespace scanprep::testing {
namespace {

std::string ReadFirstLine(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// The fields of /proc/.../stat after the command name (which may hold spaces): [0] is the state,
// [2] the process group, [11] and [12] user and system time in clock ticks.
std::vector<std::string> StatFields(const std::filesystem::path& stat) {
  const std::string line = ReadFirstLine(stat);
  const size_t close = line.rfind(')');
  if (close == std::string::npos || close + 2 >= line.size()) return {};
  return absl::StrSplit(line.substr(close + 2), ' ');
}

// The processes whose process group is `pgrp`.
std::vector<pid_t> GroupMembers(pid_t pgrp) {
  std::vector<pid_t> members;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::vector<std::string> f = StatFields(entry.path() / "stat");
    if (f.size() > 2 && f[2] == std::to_string(pgrp)) members.push_back(std::stoi(name));
  }
  return members;
}

}  // namespace

std::string ThreadStates(pid_t pid) {
  const std::filesystem::path process = std::filesystem::path("/proc") / std::to_string(pid);
  std::string command = ReadFirstLine(process / "cmdline");
  std::replace(command.begin(), command.end(), '\0', ' ');  // the arguments are NUL-separated
  std::string out = absl::StrCat("process ", pid, " ", command, "\n");
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator(process / "task", ec)) {
    const std::vector<std::string> f = StatFields(task.path() / "stat");
    if (f.size() < 13) continue;
    absl::StrAppendFormat(&out, "  thread %s %-16s %s cpu %.2f s  wchan %s\n",
                          task.path().filename().string(), ReadFirstLine(task.path() / "comm"),
                          f[0], (std::stod(f[11]) + std::stod(f[12])) / tick,
                          ReadFirstLine(task.path() / "wchan"));
  }
  return out;
}

CommandResult RunCommand(const std::string& command_line, absl::Duration limit) {
  CommandResult r;
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return r;
  const pid_t pid = fork();
  if (pid < 0) return r;
  if (pid == 0) {
    setpgid(0, 0);  // its own group, so a timeout ends the shell and everything it started
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    execl("/bin/sh", "sh", "-c", command_line.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  setpgid(pid, pid);  // also here, so the group exists before a timeout could look for it
  close(fds[1]);
  const absl::Time deadline = absl::Now() + limit;
  char buffer[4096];
  for (;;) {
    pollfd p{.fd = fds[0], .events = POLLIN, .revents = 0};
    const int wait_ms =
        static_cast<int>(std::max<int64_t>(0, absl::ToInt64Milliseconds(deadline - absl::Now())));
    if (poll(&p, 1, wait_ms) == 0) {
      r.timed_out = true;
      absl::StrAppend(&r.output, "\n--- still running after ", absl::FormatDuration(limit),
                      "; killed. Its threads:\n");
      for (pid_t member : GroupMembers(pid)) r.output += ThreadStates(member);
      kill(-pid, SIGKILL);
      break;
    }
    const ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n <= 0) break;
    r.output.append(buffer, n);
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  r.exit_code = !r.timed_out && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace scanprep::testing
