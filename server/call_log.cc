#include "server/call_log.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace scanprep::server {

void CallLog::Write(Level level, std::string_view text) {
  if (out_ == nullptr) return;
  const std::string line =
      absl::StrCat(absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::Now(), absl::UTCTimeZone()),
                   level == kInfo ? " I " : " W ", std::string(text), "\n");
  std::lock_guard lock(mu_);
  *out_ << line << std::flush;
}

std::string Quoted(std::string_view text, size_t max_chars) {
  const bool cut = text.size() > max_chars;
  const std::string escaped = absl::CEscape(std::string(text.substr(0, max_chars)));
  return absl::StrCat("\"", escaped, cut ? "...\"" : "\"");
}

}  // namespace scanprep::server
