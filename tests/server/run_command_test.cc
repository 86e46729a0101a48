// SPDX-License-Identifier: Apache-2.0
// The harness the binary tests run commands with: a hang becomes a failure that shows where the
// threads were, within the limit, and nothing the command started is left behind.
#include "tests/support/run_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/time/clock.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

TEST(RunCommand, CapturesOutputAndExitCode) {
  const CommandResult r = RunCommand("echo out; echo err >&2; exit 3");
  EXPECT_FALSE(r.timed_out);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.output, "out\nerr\n");
}

TEST(RunCommand, AHangIsKilledAtTheLimitWithItsThreadsStates) {
  const absl::Time start = absl::Now();
  // A child in the background holds the pipe as well: the whole group must go.
  const CommandResult r = RunCommand("echo started; sleep 120 & sleep 121", absl::Seconds(1));
  EXPECT_LT(absl::Now() - start, absl::Seconds(10));
  EXPECT_TRUE(r.timed_out);
  EXPECT_EQ(r.exit_code, -1);
  EXPECT_THAT(r.output, HasSubstr("started\n"));
  EXPECT_THAT(r.output, HasSubstr("sleep 120"));  // each process of the group, by command line
  EXPECT_THAT(r.output, HasSubstr("sleep 121"));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("thread [0-9]+ sleep +S cpu"));
  // Control: the same command with time to finish is not cut short.
  const CommandResult quick = RunCommand("echo started; sleep 0.2 & sleep 0.1", absl::Seconds(10));
  EXPECT_FALSE(quick.timed_out);
  EXPECT_EQ(quick.exit_code, 0);
}

}  // namespace
}  // namespace scanprep::testing
