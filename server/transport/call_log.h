// SPDX-License-Identifier: Apache-2.0
// The server's log: one line per finished or refused call (peer, job id, outcome), and lifecycle
// events. Lines never carry point data; client-supplied text (job id) is escaped and truncated,
// so a client cannot forge or flood log lines with it.
//   2024-05-01T10:00:00.123Z I process peer=ipv4:10.0.0.7:51234 job="cell-3" points=80353 OK 1.42s
//   2024-05-01T10:00:01.456Z W process peer=ipv4:10.0.0.9:40100 job="" RESOURCE_EXHAUSTED: ...
#pragma once

#include <functional>
#include <mutex>
#include <ostream>
#include <string>
#include <string_view>

#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "server/transport/log_rate_limiter.h"

namespace scanprep::server {

class CallLog {
 public:
  // Lines beyond this many per second are dropped and counted.
  static constexpr int kMaxLinesPerSecond = 50;

  // nullptr = no log. `clock` is injectable for tests.
  explicit CallLog(std::ostream* out, int max_lines_per_second = kMaxLinesPerSecond,
                   std::function<absl::Time()> clock = absl::Now)
      : out_(out), limiter_(max_lines_per_second), clock_(std::move(clock)) {}

  enum Level { kInfo, kWarning };
  // One line "<UTC time> <I|W> <text>"; thread-safe. Over the rate limit the line is dropped;
  // the next line written is preceded by "<time> W log: N lines suppressed (over M/s)".
  void Write(Level level, std::string_view text);

 private:
  std::ostream* out_;
  std::mutex mu_;
  LogRateLimiter limiter_;
  std::function<absl::Time()> clock_;
};

// `text` quoted for one log line, cut to at most `max_chars` bytes between characters (marked
// with "..."): UTF-8 characters as written, quotes, backslashes and control characters C-escaped,
// bytes that are no UTF-8 as \xNN, so that no caller's text can start a line of its own.
std::string Quoted(std::string_view text, size_t max_chars = 64);

}  // namespace scanprep::server
