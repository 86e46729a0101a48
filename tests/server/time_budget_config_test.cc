// SPDX-License-Identifier: Apache-2.0
// Default time budgets from --stage_budgets and --budget_config: parsing, precedence and precise
// errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/job/time_budget_config.h"

namespace scanprep::server {
namespace {

using ::testing::HasSubstr;

TEST(TimeBudgetConfig, StageBudgetsFlag) {
  TimeBudgetDefaults d;
  ASSERT_TRUE(ParseStageBudgets("outliers=0.2, smoothing = 0.5", d).ok());
  EXPECT_EQ(d.stage_seconds,
            (std::map<std::string, double>{{"outliers", 0.2}, {"smoothing", 0.5}}));
  EXPECT_EQ(d.total_seconds, 0);
  ASSERT_TRUE(ParseStageBudgets("", d).ok());  // empty flag: nothing changes
  EXPECT_EQ(d.stage_seconds.size(), 2u);
}

TEST(TimeBudgetConfig, FileLinesCommentsTotalAndFlagPrecedence) {
  TimeBudgetDefaults d;
  ASSERT_TRUE(ParseBudgetConfig("# line 3 budgets\n"
                                "total 2.5\n"
                                "\n"
                                "outliers\t0.3   # the spike filter\n"
                                "simplification 1\r\n",
                                "budgets.conf", d)
                  .ok());
  EXPECT_EQ(d.total_seconds, 2.5);
  EXPECT_EQ(d.stage_seconds,
            (std::map<std::string, double>{{"outliers", 0.3}, {"simplification", 1}}));
  // The flag is applied after the file and replaces its entries.
  ASSERT_TRUE(ParseStageBudgets("outliers=0.1", d).ok());
  EXPECT_EQ(d.stage_seconds.at("outliers"), 0.1);
}

TEST(TimeBudgetConfig, ErrorsNameTheSourceAndTheProblem) {
  TimeBudgetDefaults d;
  absl::Status s = ParseStageBudgets("outliers=0.2,smooth=1", d);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("--stage_budgets entry 'smooth=1': unknown stage 'smooth' "
                                     "(did you mean 'smoothing'?) (known: "));
  EXPECT_THAT(ParseStageBudgets("outliers", d).message(), HasSubstr("expected stage=seconds"));
  EXPECT_THAT(ParseStageBudgets("outliers=-1", d).message(),
              HasSubstr("'-1' is not a number of seconds >= 0"));
  EXPECT_THAT(ParseStageBudgets("outliers=inf", d).message(), HasSubstr("'inf' is not a number"));
  EXPECT_THAT(ParseStageBudgets("total=3", d).message(), HasSubstr("unknown stage 'total'"));
  EXPECT_THAT(ParseBudgetConfig("outliers 1\nsmoothing\n", "b.conf", d).message(),
              HasSubstr("b.conf:2: expected 'stage seconds'"));
  EXPECT_THAT(ParseBudgetConfig("outliers abc\n", "b.conf", d).message(),
              HasSubstr("b.conf:1: 'abc' is not a number of seconds >= 0"));
  EXPECT_EQ(ReadBudgetConfig("/nonexistent/budgets.conf", d).code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace scanprep::server
