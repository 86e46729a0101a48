// SPDX-License-Identifier: Apache-2.0
// The call log's rate limit, driven by an injected clock: a flood writes at most the limit per
// second, and the next line admitted says exactly how many were dropped.
#include <sstream>
#include <string>
#include <vector>

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

}  // namespace
}  // namespace scanprep::server
