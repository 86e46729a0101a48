// SPDX-License-Identifier: Apache-2.0
// The call log's rate limit, driven by an injected clock: a flood writes at most the limit per
// second, and the next line admitted says exactly how many were dropped.
#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "absl/strings/str_split.h"
#include "absl/time/time.h"
#include "server/transport/call_log.h"

namespace scanprep::server {
namespace {

std::vector<std::string> Lines(const std::ostringstream& out) {
  return absl::StrSplit(out.str(), '\n', absl::SkipEmpty());
}

TEST(CallLogTest, FloodIsCutToTheLimitAndTheDropCountIsReported) {
  std::ostringstream out;
  absl::Time now = absl::FromUnixSeconds(1'700'000'000);
  CallLog log(&out, /*max_lines_per_second=*/3, [&now] { return now; });

  for (int i = 0; i < 10; ++i) log.Write(CallLog::kWarning, "call " + std::to_string(i));
  std::vector<std::string> lines = Lines(out);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_TRUE(lines[2].ends_with(" W call 2")) << lines[2];

  now += absl::Milliseconds(999);  // same window: still over the limit
  log.Write(CallLog::kWarning, "call 10");
  EXPECT_EQ(Lines(out).size(), 3u);

  now += absl::Milliseconds(1);  // next window: 8 dropped (calls 3..10), then the line itself
  log.Write(CallLog::kInfo, "call 11");
  lines = Lines(out);
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_TRUE(lines[3].ends_with(" W log: 8 lines suppressed (over 3/s)")) << lines[3];
  EXPECT_TRUE(lines[4].ends_with(" I call 11")) << lines[4];

  log.Write(CallLog::kInfo, "call 12");  // counter was reset: no second note
  lines = Lines(out);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_TRUE(lines[5].ends_with(" I call 12")) << lines[5];
}

TEST(CallLogTest, UnderTheLimitEveryLineIsWritten) {
  std::ostringstream out;
  absl::Time now = absl::FromUnixSeconds(1'700'000'000);
  CallLog log(&out, /*max_lines_per_second=*/2, [&now] { return now; });
  for (int i = 0; i < 20; ++i) {
    log.Write(CallLog::kInfo, "ok");
    now += absl::Milliseconds(500);
  }
  EXPECT_EQ(Lines(out).size(), 20u);
  EXPECT_EQ(out.str().find("suppressed"), std::string::npos);
}

// Issue 40: a part named in UTF-8 was logged as octal escapes ("Pr\303\274fteil"). Characters
// are written as they are; what could break the line or the quoting is still escaped.
TEST(CallLogTest, QuotedKeepsUtf8AndEscapesWhatCouldBreakTheLine) {
  EXPECT_EQ(Quoted("Prüfteil 7°"), "\"Prüfteil 7°\"");
  EXPECT_EQ(Quoted("a\nb\"c\\"), "\"a\\nb\\\"c\\\\\"");
  EXPECT_EQ(Quoted(std::string("x\xff\xc3y")), "\"x\\xff\\xc3y\"");  // no UTF-8: escaped
  // Cut between characters: "ü" is two bytes, and a cut inside it keeps neither.
  EXPECT_EQ(Quoted("aü", 2), "\"a...\"");
  EXPECT_EQ(Quoted("aü", 3), "\"aü\"");
}

// Issue 40: logs were plain text only. With --log_format=json every line is one JSON object a
// parser reads (a collector's), a client's text (quotes, a line break, a byte no UTF-8 uses)
// escaped so it stays one string of that object, cut as in text; the text line of the same event
// keeps key=value with the client's text quoted.
TEST(CallLogTest, JsonLinesParseWithTheClientsTextInsideOneString) {
  const absl::Time at = absl::FromUnixMillis(1'700'000'000'123);
  const std::string id = std::string("Prüf\"teil\n7\xff") + std::string(100, 'x');
  const std::vector<LogField> fields = {{"peer", "ipv4:10.0.0.7:51234"},
                                        {"job", id, 64},
                                        {"points", int64_t{80353}},
                                        {"status", "OK"},
                                        {"seconds", 1.4204}};
  const std::string json =
      FormatLogLine(LogFormat::kJson, at, LogLevel::kWarning, "process", fields);
  ASSERT_TRUE(json.ends_with("}\n")) << json;
  EXPECT_EQ(std::count(json.begin(), json.end(), '\n'), 1) << json;
  google::protobuf::Struct parsed;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json, &parsed).ok()) << json;
  const auto& f = parsed.fields();
  EXPECT_EQ(f.at("time").string_value(), "2023-11-14T22:13:20.123Z");
  EXPECT_EQ(f.at("level").string_value(), "warning");
  EXPECT_EQ(f.at("event").string_value(), "process");
  EXPECT_EQ(f.at("peer").string_value(), "ipv4:10.0.0.7:51234");
  // The first 64 bytes of the id (13 before the x), the invalid byte as U+FFFD, and the mark of the
  // cut.
  EXPECT_EQ(f.at("job").string_value(), "Prüf\"teil\n7\uFFFD" + std::string(64 - 13, 'x') + "...");
  EXPECT_EQ(f.at("points").number_value(), 80353);
  EXPECT_EQ(f.at("status").string_value(), "OK");
  EXPECT_DOUBLE_EQ(f.at("seconds").number_value(), 1.4204);

  EXPECT_EQ(FormatLogLine(LogFormat::kText, at, LogLevel::kInfo, "process", fields),
            "2023-11-14T22:13:20.123Z I process peer=ipv4:10.0.0.7:51234 job=" + Quoted(id) +
                " points=80353 status=OK seconds=1.420\n");
  // A free-text line: its message alone in text, a "message" in JSON.
  EXPECT_EQ(FormatLogLine(LogFormat::kText, at, LogLevel::kInfo, "", {{"message", "guard on"}}),
            "2023-11-14T22:13:20.123Z I guard on\n");
  EXPECT_EQ(FormatLogLine(LogFormat::kJson, at, LogLevel::kInfo, "", {{"message", "guard on"}}),
            "{\"time\":\"2023-11-14T22:13:20.123Z\",\"level\":\"info\",\"message\":\"guard "
            "on\"}\n");
  EXPECT_EQ(ParseLogFormat("JSON").status().message(),
            "--log_format=JSON: the log is written as text or json");
}

}  // namespace
}  // namespace scanprep::server
