// SPDX-License-Identifier: Apache-2.0
// Presets: a named set of overrides between the declared defaults and the job's own overrides.
// The built-ins validate like a job's overrides, "paper" is the configuration docs/benchmarks.md
// measures as the paper's, and an unknown name is refused naming options.preset.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/base/field_error.h"
#include "core/pipeline/presets.h"

namespace scanprep {
namespace {

using ::testing::HasSubstr;

TEST(Presets, BuiltinsAreMetrologyAndPaperAndValidate) {
  const std::vector<Preset> presets = BuiltinPresets();
  ASSERT_EQ(presets.size(), 2u);
  EXPECT_EQ(presets[0].name, "metrology");
  EXPECT_EQ(presets[1].name, "paper");
  for (const Preset& preset : presets) {
    EXPECT_TRUE(preset.built_in) << preset.name;
    EXPECT_FALSE(preset.description.empty()) << preset.name;
    EXPECT_TRUE(ValidatePreset(preset).ok()) << preset.name << ": " << ValidatePreset(preset);
  }
  // metrology is the declared defaults: nothing to override.
  EXPECT_TRUE(presets[0].params.empty());
}

// docs/benchmarks.md and docs/algorithms.md: the paper's configuration is its global outlier rule
// without the surface test (outliers.surface_sigmas = 0) and the weighted-mean smoothing of
// Eqs. 8-10 (smoothing.method = mean), normals and smoothing from the k-NN list (the fast one).
const ParamOverrides kPaper = {{"normals.radius_mode", "knn"},
                               {"outliers.surface_sigmas", "0"},
                               {"smoothing.method", "mean"},
                               {"smoothing.neighbourhood", "knn"}};

TEST(Presets, PaperSetsThePapersConfiguration) {
  auto params = ResolvePreset(BuiltinPresets(), "paper", {});
  ASSERT_TRUE(params.ok()) << params.status();
  EXPECT_EQ(*params, kPaper);
}

TEST(Presets, DefaultThenPresetThenExplicitParameters) {
  const std::vector<Preset> presets = BuiltinPresets();
  // Neither: the job's overrides as they are, so every parameter keeps its declared default.
  auto none = ResolvePreset(presets, "", {{"smoothing.lambda", "0.7"}});
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_EQ(*none, (ParamOverrides{{"smoothing.lambda", "0.7"}}));
  auto metrology = ResolvePreset(presets, "metrology", {});
  ASSERT_TRUE(metrology.ok()) << metrology.status();
  EXPECT_TRUE(metrology->empty());
  // The preset's value where the job states none; the job's own value beats the preset's.
  auto both = ResolvePreset(presets, "paper", {{"outliers.surface_sigmas", "2"}});
  ASSERT_TRUE(both.ok()) << both.status();
  ParamOverrides expected = kPaper;
  expected["outliers.surface_sigmas"] = "2";
  EXPECT_EQ(*both, expected);
}

TEST(Presets, AnUnknownPresetIsRefusedNamingTheFieldAndTheKnownNames) {
  std::vector<Preset> presets = BuiltinPresets();
  presets.push_back({.name = "acme-ls200", .params = {{"smoothing.lambda", "0.4"}}});
  auto refused = ResolvePreset(presets, "papr", {});
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument) << refused.status();
  EXPECT_EQ(ErrorField(refused.status()), "options.preset");
  EXPECT_EQ(refused.status().message(),
            "options.preset: unknown preset 'papr' (did you mean 'paper'?) (known: metrology, "
            "paper, acme-ls200)");
  EXPECT_THAT(ResolvePreset(presets, "Fast", {}).status().message(),
              HasSubstr("unknown preset 'Fast' (known: "));
}

}  // namespace
}  // namespace scanprep
