// SPDX-License-Identifier: Apache-2.0
// scanprep-server as a subprocess on ephemeral ports, for the tests that run the real binaries
// (SCANPREP_SERVER_BINARY, tests/CMakeLists.txt).
#pragma once

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {

// The number after `marker` in a log line, 0 when the line has none.
inline int PortAfter(const std::string& line, const std::string& marker) {
  const size_t at = line.find(marker);
  return at == std::string::npos ? 0 : std::atoi(line.c_str() + at + marker.size());
}

// scanprep-server --plaintext --listen 127.0.0.1:0 --metrics_listen 127.0.0.1:0 plus `flags`, its
// stdout and stderr in a file from which both ports are read.
class ServerProcess {
 public:
  explicit ServerProcess(std::vector<std::string> flags = {}) {
    static std::atomic<int> servers{0};  // several per test process, each with its own log
    log_ = std::filesystem::path(::testing::TempDir()) /
           absl::StrCat("scanprep_server_", getpid(), "_", servers++, ".log");
    flags.insert(flags.begin(),
                 {SCANPREP_SERVER_BINARY, "--plaintext", "--listen=127.0.0.1:0",
                  "--metrics_listen=127.0.0.1:0", "--threads=2", "--grace_period=5s"});
    pid_ = fork();
    if (pid_ == 0) {
      FILE* out = std::freopen(log_.c_str(), "w", stdout);
      if (out == nullptr || dup2(fileno(out), STDERR_FILENO) < 0) _exit(127);  // the call log too
      std::vector<char*> argv;
      for (std::string& f : flags) argv.push_back(f.data());
      argv.push_back(nullptr);
      execv(SCANPREP_SERVER_BINARY, argv.data());
      _exit(127);
    }
    for (int i = 0; i < 200 && metrics_port_ == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
      std::ifstream in(log_);
      for (std::string line; std::getline(in, line);) {
        if (const int p = PortAfter(line, "listening on port "); p > 0) port_ = p;
        if (const int p = PortAfter(line, "metrics on port "); p > 0) metrics_port_ = p;
      }
    }
  }
  ~ServerProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  std::string target() const { return "127.0.0.1:" + std::to_string(port_); }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  int metrics_port() const { return metrics_port_; }
  // Everything the server printed so far (stdout and stderr).
  std::string Log() const {
    std::ifstream in(log_);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  // SIGTERM, then the exit code (-1 when it did not exit normally). A server still running a
  // minute later fails the test with its threads' states and is killed.
  int Terminate() {
    kill(pid_, SIGTERM);
    int status = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        ADD_FAILURE() << "scanprep-server did not exit within 60 s of SIGTERM\n"
                      << ThreadStates(pid_) << Log();
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        pid_ = -1;
        return -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int port_ = 0;
  int metrics_port_ = 0;
};

}  // namespace scanprep::testing
