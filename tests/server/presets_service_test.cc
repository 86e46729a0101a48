// SPDX-License-Identifier: Apache-2.0
// options.preset through the service: the report records the preset and every parameter value
// used (default < preset < the job's own parameters), an unknown name is refused naming
// header.options.preset, and GetInfo lists the presets with their overrides.
#include <map>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "client/call_error.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

// A server with the built-ins and one preset as --presets_file would add it.
server::ServerOptions WithScannerPreset() {
  std::vector<Preset> presets = BuiltinPresets();
  presets.push_back({.name = "acme-ls200",
                     .description = "Acme LS-200",
                     .params = {{"smoothing.lambda", "0.25"}, {"outliers.multiplier", "4"}}});
  server::ServerOptions options;
  options.limits.presets = std::make_shared<const std::vector<Preset>>(std::move(presets));
  return options;
}

struct Used {
  std::map<std::string, double> numbers;
  std::map<std::string, std::string> choices;
  std::string preset;
};

// The parameters the report says the job used, over every stage.
Used RunJob(InProcessServer& server, const std::string& preset,
            const std::map<std::string, std::string>& params = {}) {
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->set_preset(preset);
  header.mutable_options()->mutable_params()->insert(params.begin(), params.end());
  auto result = server.Client().Process(header, NoisyPlaneWithSpikes(30, 0.5f).cloud);
  EXPECT_TRUE(result.ok()) << result.status();
  Used used;
  if (!result.ok()) return used;
  used.preset = result->report.preset();
  for (const v1::StageReport& stage : result->report.stages()) {
    used.numbers.insert(stage.parameters().begin(), stage.parameters().end());
    used.choices.insert(stage.text_parameters().begin(), stage.text_parameters().end());
  }
  return used;
}

// The declared defaults (docs/algorithms.md): surface test at 4σ, own-side smoothing, λ = 0.5,
// outlier multiplier 2.
TEST(PresetsService, NoPresetRunsTheDeclaredDefaults) {
  InProcessServer server(WithScannerPreset());
  const Used used = RunJob(server, "");
  EXPECT_EQ(used.preset, "");
  EXPECT_EQ(used.numbers.at("outliers.surface_sigmas"), 4);
  EXPECT_EQ(used.choices.at("smoothing.method"), "own_side");
  EXPECT_EQ(used.numbers.at("smoothing.lambda"), 0.5);
  EXPECT_EQ(used.numbers.at("outliers.multiplier"), 2);
}

// The paper's configuration as docs/benchmarks.md measures it: outliers.surface_sigmas = 0 (its
// global rule alone) and smoothing.method = mean (Eqs. 8-10); everything else at its default.
TEST(PresetsService, PaperRunsThePapersConfigurationAndTheReportSaysSo) {
  InProcessServer server(WithScannerPreset());
  const Used used = RunJob(server, "paper");
  EXPECT_EQ(used.preset, "paper");
  EXPECT_EQ(used.numbers.at("outliers.surface_sigmas"), 0);
  EXPECT_EQ(used.choices.at("smoothing.method"), "mean");
  EXPECT_EQ(used.numbers.at("smoothing.lambda"), 0.5);
}

TEST(PresetsService, AnExplicitParameterBeatsThePreset) {
  InProcessServer server(WithScannerPreset());
  const Used used = RunJob(server, "acme-ls200", {{"smoothing.lambda", "0.75"}});
  EXPECT_EQ(used.preset, "acme-ls200");
  EXPECT_EQ(used.numbers.at("smoothing.lambda"), 0.75);      // the job's own
  EXPECT_EQ(used.numbers.at("outliers.multiplier"), 4);      // the preset's
  EXPECT_EQ(used.numbers.at("outliers.surface_sigmas"), 4);  // the default
}

TEST(PresetsService, AnUnknownPresetIsRefusedNamingTheField) {
  InProcessServer server(WithScannerPreset());
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->set_preset("acme-ls20");
  const auto refused = server.Client().Process(header, NoisyPlaneWithSpikes(10, 0.5f).cloud);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument) << refused.status();
  EXPECT_EQ(client::Describe(refused.status()),
            "INVALID_ARGUMENT: options.preset: unknown preset 'acme-ls20' (did you mean "
            "'acme-ls200'?) (known: metrology, paper, acme-ls200) (reason INVALID_PARAMETER; field "
            "header.options.preset)");
}

TEST(PresetsService, GetInfoListsThePresetsWithTheirOverrides) {
  InProcessServer server(WithScannerPreset());
  auto info = server.Client().GetInfo(absl::Seconds(10));
  ASSERT_TRUE(info.ok()) << info.status();
  ASSERT_EQ(info->presets_size(), 3);
  EXPECT_EQ(info->presets(0).name(), "metrology");
  EXPECT_TRUE(info->presets(0).built_in());
  EXPECT_TRUE(info->presets(0).params().empty());
  EXPECT_EQ(info->presets(1).name(), "paper");
  EXPECT_EQ(info->presets(1).params().at("smoothing.method"), "mean");
  EXPECT_EQ(info->presets(1).params().at("outliers.surface_sigmas"), "0");
  const v1::PresetInfo& acme = info->presets(2);
  EXPECT_EQ(acme.name(), "acme-ls200");
  EXPECT_FALSE(acme.built_in());
  EXPECT_EQ(acme.description(), "Acme LS-200");
  EXPECT_EQ(acme.params().size(), 2u);
  EXPECT_EQ(acme.params().at("smoothing.lambda"), "0.25");
}

}  // namespace
}  // namespace scanprep::testing
