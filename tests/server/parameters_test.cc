// SPDX-License-Identifier: Apache-2.0
// Parameters through the service: GetInfo states each one's kind, default and valid range; a job
// reports the choices it ran with; an out-of-range integer is refused before any work.
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

std::map<std::string, v1::ParameterInfo> InfoByName(InProcessServer& server) {
  auto info = server.Client().GetInfo(absl::Seconds(10));
  EXPECT_TRUE(info.ok()) << info.status();
  std::map<std::string, v1::ParameterInfo> by_name;
  if (info.ok()) {
    for (const v1::ParameterInfo& p : info->parameters()) by_name[p.name()] = p;
  }
  return by_name;
}

TEST(Parameters, GetInfoStatesKindDefaultAndRange) {
  InProcessServer server;
  std::map<std::string, v1::ParameterInfo> params = InfoByName(server);

  const v1::ParameterInfo& rounds = params["correction.rounds"];
  EXPECT_EQ(rounds.kind(), v1::PARAMETER_KIND_INTEGER);
  EXPECT_EQ(rounds.default_value(), "10");
  EXPECT_FALSE(rounds.default_derived());
  EXPECT_EQ(rounds.min(), 1);
  EXPECT_EQ(rounds.max(), 1000);
  EXPECT_TRUE(rounds.min_inclusive() && rounds.max_inclusive());
  EXPECT_EQ(rounds.range(), "[1, 1000]");

  const v1::ParameterInfo& radius = params["correction.radius_mm"];
  EXPECT_EQ(radius.kind(), v1::PARAMETER_KIND_REAL);
  EXPECT_TRUE(radius.default_derived());
  EXPECT_FALSE(radius.min_inclusive());
  EXPECT_EQ(radius.range(), "(0, 10000]");

  const v1::ParameterInfo& epsilon = params["normals.mitra_epsilon"];
  EXPECT_EQ(epsilon.default_value(), "0.05");
  EXPECT_EQ(epsilon.range(), "(0, 1)");

  const v1::ParameterInfo& k = params["outliers.k"];
  EXPECT_EQ(k.range(), "[1, 64]");
  EXPECT_EQ(k.at_most(), "neighbourhoods.k");

  const v1::ParameterInfo& method = params["outliers.method"];
  EXPECT_EQ(method.kind(), v1::PARAMETER_KIND_CHOICE);
  EXPECT_EQ(method.default_value(), "nn");
  EXPECT_EQ(method.range(), "");

  // Every numeric parameter has a non-empty, finite range.
  for (const auto& [name, p] : params) {
    if (p.kind() == v1::PARAMETER_KIND_CHOICE) continue;
    EXPECT_TRUE(p.kind() == v1::PARAMETER_KIND_REAL || p.kind() == v1::PARAMETER_KIND_INTEGER)
        << name;
    EXPECT_LT(p.min(), p.max()) << name;
    EXPECT_LE(p.max(), 1e4) << name;
    EXPECT_FALSE(p.range().empty()) << name;
  }
}

TEST(Parameters, TheReportCarriesTheChoicesUsed) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("outliers");
  header.mutable_options()->add_stages("smoothing");
  (*header.mutable_options()->mutable_params())["smoothing.influence"] = "gauss";
  auto result = server.Client().Process(header, NoisyPlaneWithSpikes(40, 0.5f).cloud);
  ASSERT_TRUE(result.ok()) << result.status();
  std::map<std::string, std::string> text;
  for (const v1::StageReport& stage : result->report.stages()) {
    for (const auto& [name, value] : stage.text_parameters()) text[name] = value;
  }
  EXPECT_EQ(text["outliers.method"], "nn");            // the default
  EXPECT_EQ(text["smoothing.influence"], "gauss");     // as requested
  EXPECT_EQ(text["normals.radius_mode"], "adaptive");  // pulled in by smoothing
}

TEST(Parameters, AnIntegerOverflowIsRefusedBeforeAnyWork) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("correction");
  (*header.mutable_options()->mutable_params())["correction.rounds"] = "1e30";
  auto result = server.Client().Process(header, NoisyPlaneWithSpikes(20, 0.5f).cloud);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(result.status().message(),
            "options.params['correction.rounds']: 1e+30 is outside [1, 1000]");
}

}  // namespace
}  // namespace scanprep::testing
