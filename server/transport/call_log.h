// SPDX-License-Identifier: Apache-2.0
// The server's log: one line per finished or refused call (peer, job id, outcome), and lifecycle
// events, as text (key=value after the event's name) or one JSON object a line (--log_format).
// Lines never carry point data; client-supplied text (job id) is escaped and truncated, so a
// client cannot forge or flood log lines with it.
//   2024-05-01T10:00:00.123Z I process peer=ipv4:10.0.0.7:51234 client=10.0.0.7 job="cell-3"
//       points=80353 status=OK seconds=1.420
//   {"time":"2024-05-01T10:00:00.123Z","level":"info","event":"process","peer":"ipv4:...",
//       "client":"10.0.0.7","job":"cell-3","points":80353,"status":"OK","seconds":1.42}
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <ostream>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "server/transport/log_rate_limiter.h"

namespace scanprep::server {

enum class LogFormat { kText, kJson };

// How much of a client's text (a job id) and of an error message a log line keeps.
inline constexpr size_t kLoggedClientTextBytes = 64;
inline constexpr size_t kLoggedMessageBytes = 300;
// "text" or "json"; INVALID_ARGUMENT naming --log_format and the two otherwise.
absl::StatusOr<LogFormat> ParseLogFormat(std::string_view name);

// One field of a log event. A string is the server's own word (a status code, an address), bare
// in a text line, unless `quote_chars` is set (a client's text, a message): then it is quoted and
// cut to that many bytes (Quoted). JSON escapes every string and cuts the same ones.
struct LogField {
  std::string key;
  std::variant<std::string, int64_t, double> value;
  size_t quote_chars = 0;
};

enum class LogLevel { kInfo, kWarning };

// One line of the log in `format`, with its newline: "<time> I|W <event> key=value..." or a JSON
// object with time, level, event (when not empty) and the fields. A free-text line is an event
// without a name and one field "message".
std::string FormatLogLine(LogFormat format, absl::Time time, LogLevel level, std::string_view event,
                          const std::vector<LogField>& fields);

class CallLog {
 public:
  using Level = LogLevel;
  static constexpr Level kInfo = LogLevel::kInfo;
  static constexpr Level kWarning = LogLevel::kWarning;
  // Lines beyond this many per second are dropped and counted.
  static constexpr int kMaxLinesPerSecond = 50;

  // nullptr = no log. `clock` is injectable for tests.
  explicit CallLog(std::ostream* out, int max_lines_per_second = kMaxLinesPerSecond,
                   std::function<absl::Time()> clock = absl::Now,
                   LogFormat format = LogFormat::kText)
      : out_(out), limiter_(max_lines_per_second), clock_(std::move(clock)), format_(format) {}

  // One event; thread-safe. Over the rate limit the line is dropped; the next line written is
  // preceded by a warning "log: N lines suppressed (over M/s)".
  void Write(Level level, std::string_view event, const std::vector<LogField>& fields);
  // A free-text line (the server's own words).
  void Write(Level level, std::string_view text);

 private:
  std::ostream* out_;
  std::mutex mu_;
  LogRateLimiter limiter_;
  std::function<absl::Time()> clock_;
  LogFormat format_;
};

// `text` quoted for one log line, cut to at most `max_chars` bytes between characters (marked
// with "..."): UTF-8 characters as written, quotes, backslashes and control characters escaped,
// so that no caller's text can start a line of its own. Text: C escapes, bytes that are no UTF-8
// as \xNN. JSON: JSON's escapes, a byte that is no UTF-8 as U+FFFD (JSON text is UTF-8).
std::string Quoted(std::string_view text, size_t max_chars = 64,
                   LogFormat format = LogFormat::kText);

}  // namespace scanprep::server
