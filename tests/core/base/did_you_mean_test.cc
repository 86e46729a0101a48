// SPDX-License-Identifier: Apache-2.0
// A misspelt parameter or stage name is refused with the name it was probably meant to be, and
// only with a near one: the distances below are counted by hand.
#include "core/base/did_you_mean.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/base/field_error.h"
#include "core/pipeline/pipeline.h"

namespace scanprep {
namespace {

using ::testing::HasSubstr;

TEST(DidYouMean, ClosestNameWithinAThirdOfTheLength) {
  const std::vector<std::string> known = {"smoothing.iterations", "smoothing.lambda", "outliers.k"};
  EXPECT_EQ(ClosestName("smoothing.iteratons", known), "smoothing.iterations");   // 1 deletion
  EXPECT_EQ(ClosestName("smoothing.iteratoins", known), "smoothing.iterations");  // 1 swap
  EXPECT_EQ(ClosestName("outlier.k", known), "outliers.k");                       // 1 of 3
  EXPECT_EQ(ClosestName("outliers.sigma", known), "");  // 5 edits from outliers.k, limit 4
  EXPECT_EQ(ClosestName("voxel", known), "");
  EXPECT_EQ(ClosestName("x", {"y"}), "y");  // a one-letter name: one edit is always allowed
  // Ties go to the first listed.
  EXPECT_EQ(ClosestName("ab", {"ac", "ad"}), "ac");
  EXPECT_EQ(DidYouMean("outlier.k", known), " (did you mean 'outliers.k'?)");
  EXPECT_EQ(DidYouMean("voxel", known), "");
}

TEST(DidYouMean, UnknownParameterAndStageNameTheirNearestKnownName) {
  absl::Status s = ValidateOptions({.params = {{"smoothing.iteratons", "3"}}});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ErrorField(s), "options.params['smoothing.iteratons']");
  EXPECT_THAT(s.message(), HasSubstr("unknown parameter (did you mean 'smoothing.iterations'?)"));

  s = ValidateOptions({.stages = {"outliers", "smothing"}});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("unknown stage 'smothing' (did you mean 'smoothing'?)"));

  s = ValidateOptions({.stage_budget_seconds = {{"simplfication", 1.0}}});
  EXPECT_THAT(s.message(), HasSubstr("unknown stage (did you mean 'simplification'?)"));

  // Control: nothing near, no guess.
  s = ValidateOptions({.stages = {"sharpen"}});
  EXPECT_THAT(s.message(), HasSubstr("unknown stage 'sharpen' (known: "));
}

}  // namespace
}  // namespace scanprep
