// SPDX-License-Identifier: Apache-2.0
// --presets_file: presets per scanner model, validated at startup exactly like a job's overrides;
// a bad file is refused naming the file, the line, the preset and the key.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"

#include "server/job/presets_file.h"

namespace scanprep::server {
namespace {

using ::testing::HasSubstr;

// Control: a good file loads, after the built-ins, with comments, blank lines and spaces.
TEST(PresetsFile, AGoodFileLoadsAfterTheBuiltins) {
  auto presets = ParsePresets(
      "# line 3\n"
      "[acme-ls200]\n"
      "description = Acme LS-200 laser line scanner\n"
      "  smoothing.lambda = 0.4   # its intensity is noisy\n"
      "\n"
      "outliers.method=loop\r\n"
      "[fringe.v2]\n"
      "outliers.k = 24   # before the k it must not exceed: checked per preset, not per line\n"
      "neighbourhoods.k = 32\n"
      "[plain]\n",
      "presets.conf");
  ASSERT_TRUE(presets.ok()) << presets.status();
  ASSERT_EQ(presets->size(), 5u);
  EXPECT_EQ((*presets)[0].name, "metrology");
  EXPECT_EQ((*presets)[1].name, "paper");
  const Preset& acme = (*presets)[2];
  EXPECT_EQ(acme.name, "acme-ls200");
  EXPECT_FALSE(acme.built_in);
  EXPECT_EQ(acme.description, "Acme LS-200 laser line scanner");
  EXPECT_EQ(acme.params,
            (ParamOverrides{{"smoothing.lambda", "0.4"}, {"outliers.method", "loop"}}));
  EXPECT_EQ((*presets)[3].params,
            (ParamOverrides{{"outliers.k", "24"}, {"neighbourhoods.k", "32"}}));
  EXPECT_TRUE((*presets)[4].params.empty());
}

TEST(PresetsFile, ABadParameterIsRefusedNamingFileLinePresetAndKey) {
  const auto message = [](const std::string& text) {
    const absl::Status s = ParsePresets(text, "p.conf").status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << text;
    return std::string(s.message());
  };
  EXPECT_EQ(message("[acme]\nsmoothing.lambda = 0.4\nsmoothing.lamda = 0.5\n"),
            "p.conf:3: [acme] smoothing.lamda: unknown parameter (did you mean "
            "'smoothing.lambda'?)");
  EXPECT_EQ(message("[acme]\n\nsmoothing.lambda = 1.5\n"),
            "p.conf:3: [acme] smoothing.lambda: 1.5 is outside [0, 1]");
  EXPECT_EQ(message("[acme]\nsmoothing.method = median\n"),
            "p.conf:2: [acme] smoothing.method: 'median' is not one of own_side, mean");
  // Bounds between parameters are checked over the whole preset: outliers.k above the default
  // neighbourhoods.k (20) is named on its own line.
  EXPECT_EQ(message("[a]\nsmoothing.lambda = 0.4\n[b]\noutliers.k = 24\nsmoothing.lambda = 0.4\n"),
            "p.conf:4: [b] outliers.k: 24 is above neighbourhoods.k = 20");
}

TEST(PresetsFile, TheFileCannotRedefineABuiltinOrRepeatItself) {
  const auto message = [](const std::string& text) {
    return std::string(ParsePresets(text, "p.conf").status().message());
  };
  EXPECT_EQ(message("[paper]\nsmoothing.lambda = 0.4\n"),
            "p.conf:1: [paper] is a built-in preset; a file cannot redefine it (names are compared "
            "ignoring case)");
  EXPECT_EQ(message("[a]\n[b]\n[a]\n"),
            "p.conf:3: [a] is defined twice (names are compared ignoring case)");
  EXPECT_EQ(message("[Paper]\n"),
            "p.conf:1: [Paper] is a built-in preset; a file cannot redefine "
            "it (names are compared ignoring case)");
  EXPECT_EQ(message("[acme]\n[ACME]\n"),
            "p.conf:2: [ACME] is defined twice (names are compared ignoring case)");
  EXPECT_EQ(message("[a]\nsmoothing.lambda = 0.4\nsmoothing.lambda = 0.5\n"),
            "p.conf:3: [a] smoothing.lambda: given twice");
  EXPECT_EQ(message("smoothing.lambda = 0.4\n[a]\n"),
            "p.conf:1: smoothing.lambda: outside a preset; start one with '[name]'");
  EXPECT_THAT(message("[a b]\n"), HasSubstr("p.conf:1: expected '[name]'"));
  EXPECT_THAT(message("[a\n"), HasSubstr("p.conf:1: expected '[name]'"));
  EXPECT_EQ(message("[a]\nsmoothing.lambda 0.4\n"), "p.conf:2: expected 'parameter = value'");
}

// GetInfo lists every preset, so the file is bounded: 256 presets, 256-byte descriptions.
TEST(PresetsFile, ManyPresetsOrLongDescriptionsAreRefused) {
  std::string file;
  for (int i = 0; i < 256; ++i) file += absl::StrCat("[p", i, "]\n");
  EXPECT_TRUE(ParsePresets(file, "p.conf").ok()) << "control: 256 presets";
  EXPECT_EQ(ParsePresets(file + "[one-more]\n", "p.conf").status().message(),
            "p.conf:257: [one-more]: more than 256 presets");
  EXPECT_TRUE(ParsePresets("[a]\ndescription = " + std::string(256, 'x') + "\n", "p.conf").ok());
  EXPECT_EQ(ParsePresets("[a]\ndescription = " + std::string(257, 'x') + "\n", "p.conf")
                .status()
                .message(),
            "p.conf:2: [a] description: 257 bytes, more than 256");
}

// A FIFO would block the server's startup in open() until something wrote to it.
TEST(PresetsFile, OnlyARegularFileIsRead) {
  const std::string dir = ::testing::TempDir() + "/presets_fifo_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const std::string fifo = dir + "/presets.conf";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const absl::Status refused = LoadPresets(fifo).status();
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.message(), HasSubstr("not a regular file"));
  EXPECT_THAT(LoadPresets(dir).status().message(), HasSubstr("not a regular file"));
  const std::string big = dir + "/big.conf";
  std::ofstream(big) << "[a]\n" << std::string(1 << 20, '#') << "\n";
  EXPECT_THAT(LoadPresets(big).status().message(), HasSubstr("more than 1048576"));
  std::filesystem::remove_all(dir);
}

TEST(PresetsFile, LoadingReadsTheFileOrGivesTheBuiltins) {
  auto builtins = LoadPresets("");
  ASSERT_TRUE(builtins.ok()) << builtins.status();
  EXPECT_EQ(builtins->size(), BuiltinPresets().size());
  EXPECT_EQ(LoadPresets("/nonexistent/presets.conf").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace scanprep::server
