// SPDX-License-Identifier: Apache-2.0
#include "server/transport/call_log.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace scanprep::server {

void CallLog::Write(Level level, std::string_view text) {
  if (out_ == nullptr) return;
  std::lock_guard lock(mu_);
  const absl::Time now = clock_();
  const std::optional<int64_t> dropped = limiter_.Admit(now);
  if (!dropped) return;
  const std::string time = absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", now, absl::UTCTimeZone());
  if (*dropped > 0) {
    *out_ << absl::StrCat(time, " W log: ", *dropped, " lines suppressed (over ",
                          limiter_.max_per_second(), "/s)\n");
  }
  *out_ << absl::StrCat(time, level == kInfo ? " I " : " W ", std::string(text), "\n")
        << std::flush;
}

std::string Quoted(std::string_view text, size_t max_chars) {
  const bool cut = text.size() > max_chars;
  const std::string escaped = absl::CEscape(std::string(text.substr(0, max_chars)));
  return absl::StrCat("\"", escaped, cut ? "...\"" : "\"");
}

}  // namespace scanprep::server
