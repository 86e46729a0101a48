// SPDX-License-Identifier: Apache-2.0
// The CLI's flag parsing (CLI11 behind the FlagSpec tables): the forms the commands document.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/cli_args.h"

namespace scanprep::client {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

const std::vector<FlagSpec> kSpecs = {
    {"server", FlagSpec::kValue, "target"},
    {"output", FlagSpec::kValue, "output file", "o"},
    {"param", FlagSpec::kRepeated, "NAME=VALUE"},
    {"include_removed", FlagSpec::kBool, "also removed points"},
};

TEST(CliArgs, ValuesAliasesRepeatsBoolsAndPositionals) {
  auto args = ParseArgs({"a.ply", "--server", "h:1", "-o", "out.ply", "--param", "x=-1", "b.ply",
                         "--param=y=2", "--include_removed", "-"},
                        kSpecs);
  ASSERT_TRUE(args.ok()) << args.status();
  EXPECT_EQ(args->Get("server"), "h:1");
  EXPECT_EQ(args->Get("output"), "out.ply");
  EXPECT_THAT(args->All("param"), ElementsAre("x=-1", "y=2"));
  EXPECT_TRUE(args->Bool("include_removed"));
  EXPECT_THAT(args->positional, ElementsAre("a.ply", "b.ply", "-"));
  EXPECT_FALSE(ParseArgs({"a.ply"}, kSpecs)->Has("server"));
  EXPECT_FALSE(ParseArgs({"--include_removed=false"}, kSpecs)->Bool("include_removed"));
  EXPECT_TRUE(ParseArgs({"--include_removed=false"}, kSpecs)->Has("include_removed"));
}

TEST(CliArgs, MistakesAreNamed) {
  EXPECT_THAT(ParseArgs({"--frobnicate"}, kSpecs).status().message(),
              HasSubstr("unknown flag '--frobnicate'"));
  EXPECT_FALSE(ParseArgs({"--server"}, kSpecs).ok());                            // no value
  EXPECT_FALSE(ParseArgs({"--server", "a:1", "--server", "b:2"}, kSpecs).ok());  // twice
  EXPECT_THAT(ParseArgs({"--server"}, kSpecs).status().message(), HasSubstr("server"));
}

}  // namespace
}  // namespace scanprep::client
