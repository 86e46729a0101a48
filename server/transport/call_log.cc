// SPDX-License-Identifier: Apache-2.0
#include "server/transport/call_log.h"

#include <algorithm>

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

namespace {

// The length of the UTF-8 sequence of two to four bytes (a lead byte and its continuation
// bytes) at text[i], or 0 when there is none: an ASCII byte, a stray or missing continuation
// byte, a byte no UTF-8 uses.
size_t Utf8SequenceAt(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  const size_t length = lead >= 0xF0 && lead <= 0xF4   ? 4
                        : lead >= 0xE0 && lead <= 0xEF ? 3
                        : lead >= 0xC2 && lead <= 0xDF ? 2
                                                       : 0;
  if (length == 0 || i + length > text.size()) return 0;
  for (size_t k = i + 1; k < i + length; ++k) {
    if ((byte(k) & 0xC0) != 0x80) return 0;
  }
  return length;
}

}  // namespace

std::string Quoted(std::string_view text, size_t max_chars) {
  size_t end = std::min(text.size(), max_chars);
  // Cut between characters, not inside one.
  while (end < text.size() && end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) {
    --end;
  }
  std::string out = "\"";
  for (size_t i = 0; i < end;) {
    const size_t length = Utf8SequenceAt(text.substr(0, end), i);
    if (length > 0) {  // a character beyond ASCII, as written (a part named "Prüfteil")
      out.append(text.substr(i, length));
      i += length;
    } else {  // ASCII: quotes, backslashes and control characters escaped; other bytes as \xNN
      const unsigned char c = static_cast<unsigned char>(text[i++]);
      out += c < 0x80 ? absl::CEscape(std::string(1, static_cast<char>(c)))
                      : absl::StrCat("\\x", absl::Hex(c, absl::kZeroPad2));
    }
  }
  return absl::StrCat(out, end < text.size() ? "...\"" : "\"");
}

}  // namespace scanprep::server
