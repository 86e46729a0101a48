// The server's log: one line per finished or refused call (peer, job id, outcome), and lifecycle
// events. Lines never carry point data; client-supplied text (job id) is escaped and truncated,
// so a client cannot forge or flood log lines with it.
//   2024-05-01T10:00:00.123Z I process peer=ipv4:10.0.0.7:51234 job="cell-3" points=80353 OK 1.42s
//   2024-05-01T10:00:01.456Z W process peer=ipv4:10.0.0.9:40100 job="" RESOURCE_EXHAUSTED: ...
#pragma once

#include <mutex>
#include <ostream>
#include <string>
#include <string_view>

namespace scanprep::server {

class CallLog {
 public:
  // nullptr = no log.
  explicit CallLog(std::ostream* out) : out_(out) {}

  enum Level { kInfo, kWarning };
  // One line "<UTC time> <I|W> <text>"; thread-safe.
  void Write(Level level, std::string_view text);

 private:
  std::ostream* out_;
  std::mutex mu_;
};

// `text` quoted and C-escaped, cut to `max_chars` characters first (marked with "...").
std::string Quoted(std::string_view text, size_t max_chars = 64);

}  // namespace scanprep::server
