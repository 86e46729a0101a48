// SPDX-License-Identifier: Apache-2.0
// The flags process, health and load share (CallFlags): declared once, with one default each.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "client/call_flags.h"
#include "client/connection_flags.h"

namespace scanprep::client {
namespace {

using ::testing::HasSubstr;

absl::StatusOr<CallFlags> Parse(const std::vector<std::string>& words, bool server_required) {
  auto args = ParseArgs(words, CallFlagSpecs(server_required));
  if (!args.ok()) return args.status();
  return CallFlags::Parse(*args);
}

// Without the flags: no deadline and no budget (the job file's or the server's), for every
// command; `load`, which requires --server, once gave its calls 120 s.
TEST(CallFlags, NoDeadlineAndNoBudgetUnlessGiven) {
  for (bool server_required : {false, true}) {
    auto flags = Parse({"scan.ply"}, server_required);
    ASSERT_TRUE(flags.ok()) << flags.status();
    EXPECT_EQ(flags->timeout, std::nullopt);
    EXPECT_EQ(flags->budget_seconds, std::nullopt);
    EXPECT_EQ(flags->server, kDefaultServer);
  }
  auto flags = Parse({"--timeout", "90s", "--budget", "2.5", "--server", "h:1"}, true);
  ASSERT_TRUE(flags.ok()) << flags.status();
  EXPECT_EQ(flags->timeout, absl::Seconds(90));
  EXPECT_EQ(flags->budget_seconds, 2.5);
  EXPECT_EQ(flags->server, "h:1");
}

TEST(CallFlags, ValuesThatDoNotParseNameTheirFlag) {
  EXPECT_THAT(Parse({"--timeout", "5"}, false).status().message(), HasSubstr("--timeout: '5'"));
  EXPECT_THAT(Parse({"--budget", "soon"}, false).status().message(),
              HasSubstr("--budget: 'soon' is not a number >= 0"));
  EXPECT_THAT(Parse({"--server", "a:1,b"}, false).status().message(), HasSubstr("--server: 'a:1'"));
}

// One table for every command: each flag once, --server's help saying its default only where it
// has one.
TEST(CallFlags, EachFlagOnceInTheTable) {
  for (bool server_required : {false, true}) {
    const std::vector<FlagSpec> specs = CallFlagSpecs(server_required);
    for (const FlagSpec& spec : specs) {
      EXPECT_EQ(std::count_if(specs.begin(), specs.end(),
                              [&](const FlagSpec& s) { return s.name == spec.name; }),
                1)
          << spec.name;
    }
    const auto server = std::find_if(specs.begin(), specs.end(),
                                     [](const FlagSpec& s) { return s.name == kServerFlag; });
    ASSERT_NE(server, specs.end());
    EXPECT_EQ(server->help.find(kDefaultServer) != std::string::npos, !server_required);
  }
}

}  // namespace
}  // namespace scanprep::client
