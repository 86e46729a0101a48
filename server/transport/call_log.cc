// SPDX-License-Identifier: Apache-2.0
#include "server/transport/call_log.h"

#include <algorithm>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace scanprep::server {
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

// One byte that is ASCII or no UTF-8, escaped for `format` where it could break a line or quotes.
std::string EscapedByte(unsigned char c, LogFormat format) {
  if (format == LogFormat::kText) {
    return c < 0x80 ? absl::CEscape(std::string(1, static_cast<char>(c)))
                    : absl::StrCat("\\x", absl::Hex(c, absl::kZeroPad2));
  }
  if (c >= 0x80) return "\\ufffd";
  if (c == '"' || c == '\\') return absl::StrCat("\\", std::string(1, static_cast<char>(c)));
  if (c < 0x20 || c == 0x7f) return absl::StrFormat("\\u%04x", c);
  return std::string(1, static_cast<char>(c));
}

// A field's value in a text line: numbers as numbers (seconds to the millisecond), the server's
// words bare, quoted text quoted.
std::string TextValue(const LogField& field) {
  if (const auto* n = std::get_if<int64_t>(&field.value)) return absl::StrCat(*n);
  if (const auto* x = std::get_if<double>(&field.value)) return absl::StrFormat("%.3f", *x);
  const std::string& text = std::get<std::string>(field.value);
  return field.quote_chars > 0 ? Quoted(text, field.quote_chars) : text;
}

std::string JsonValue(const LogField& field) {
  if (const auto* n = std::get_if<int64_t>(&field.value)) return absl::StrCat(*n);
  if (const auto* x = std::get_if<double>(&field.value)) return absl::StrFormat("%.6g", *x);
  const std::string& text = std::get<std::string>(field.value);
  return Quoted(text, field.quote_chars > 0 ? field.quote_chars : text.size(), LogFormat::kJson);
}

}  // namespace

absl::StatusOr<LogFormat> ParseLogFormat(std::string_view name) {
  if (name == "text") return LogFormat::kText;
  if (name == "json") return LogFormat::kJson;
  return absl::InvalidArgumentError(
      absl::StrCat("--log_format=", std::string(name), ": the log is written as text or json"));
}

std::string FormatLogLine(LogFormat format, absl::Time time, LogLevel level, std::string_view event,
                          const std::vector<LogField>& fields) {
  const std::string when = absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", time, absl::UTCTimeZone());
  const bool info = level == LogLevel::kInfo;
  std::string line;
  if (format == LogFormat::kText) {
    line = absl::StrCat(when, info ? " I" : " W", event.empty() ? "" : " ", std::string(event));
    for (const LogField& field : fields) {
      // A free-text line is its message alone.
      absl::StrAppend(&line, " ", event.empty() ? "" : absl::StrCat(field.key, "="),
                      TextValue(field));
    }
  } else {
    line = absl::StrCat("{\"time\":\"", when, "\",\"level\":\"", info ? "info" : "warning", "\"");
    if (!event.empty()) absl::StrAppend(&line, ",\"event\":", Quoted(event, event.size(), format));
    for (const LogField& field : fields) {
      absl::StrAppend(&line, ",", Quoted(field.key, field.key.size(), format), ":",
                      JsonValue(field));
    }
    line += "}";
  }
  return line + "\n";
}

void CallLog::Write(Level level, std::string_view event, const std::vector<LogField>& fields) {
  if (out_ == nullptr) return;
  std::lock_guard lock(mu_);
  const absl::Time now = clock_();
  const std::optional<int64_t> dropped = limiter_.Admit(now);
  if (!dropped) return;
  if (*dropped > 0) {
    *out_ << FormatLogLine(format_, now, kWarning, "",
                           {{"message", absl::StrCat("log: ", *dropped, " lines suppressed (over ",
                                                     limiter_.max_per_second(), "/s)")}});
  }
  *out_ << FormatLogLine(format_, now, level, event, fields) << std::flush;
}

void CallLog::Write(Level level, std::string_view text) {
  Write(level, "", {{"message", std::string(text)}});
}

std::string Quoted(std::string_view text, size_t max_chars, LogFormat format) {
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
    } else {
      out += EscapedByte(static_cast<unsigned char>(text[i++]), format);
    }
  }
  return absl::StrCat(out, end < text.size() ? "...\"" : "\"");
}

}  // namespace scanprep::server
