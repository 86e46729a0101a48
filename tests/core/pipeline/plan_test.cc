// SPDX-License-Identifier: Apache-2.0
// The plan is the only authority on what runs: resolved and validated before the first step (a
// step without its prerequisites before it is refused, so no runner ever gets it), and the report
// lists exactly the plan's steps, in its order.
#include "core/pipeline/plan.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

std::vector<const StageInfo*> Steps(const std::vector<std::string>& names) {
  std::vector<const StageInfo*> steps;
  for (const std::string& name : names) steps.push_back(FindStage(name));
  return steps;
}

std::vector<std::string> Names(const std::vector<const StageInfo*>& steps) {
  std::vector<std::string> names;
  for (const StageInfo* step : steps) names.push_back(step->name);
  return names;
}

void ExpectRefused(const absl::StatusOr<Plan>& plan, const std::string& step,
                   const std::string& missing) {
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(plan.status().message().find("'" + step + "' needs stage '" + missing + "'"),
            std::string::npos)
      << plan.status();
}

// A hand-built plan whose step lacks a prerequisite is refused when it is built: there is no plan
// to hand a runner, so nothing runs. Each refusal has its control, the same plan made whole.
TEST(Plan, AStepWithoutItsPrerequisiteBeforeItIsRefused) {
  ExpectRefused(Plan::FromStages(Steps({"normals"}), {}), "normals", "neighbourhoods");
  // In the wrong order is as missing.
  ExpectRefused(Plan::FromStages(Steps({"normals", "neighbourhoods"}), {}), "normals",
                "neighbourhoods");
  EXPECT_TRUE(Plan::FromStages(Steps({"neighbourhoods", "normals"}), {}).ok());

  // The outlier stage's surface test needs normals fitted before it runs (method nn)...
  ExpectRefused(Plan::FromStages(Steps({"neighbourhoods", "outliers"}), {}), "outliers", "normals");
  // ... and without the surface test it does not: prerequisites follow the parameters.
  EXPECT_TRUE(
      Plan::FromStages(Steps({"neighbourhoods", "outliers"}), {{"outliers.surface_sigmas", "0"}})
          .ok());

  // LoOP's surface test is a step of its own, after the outliers and the normals.
  const ParamOverrides loop = {{"outliers.method", "loop"}};
  ExpectRefused(Plan::FromStages(Steps({"neighbourhoods", "normals", "surface_spikes"}), loop),
                "surface_spikes", "outliers");
  EXPECT_TRUE(
      Plan::FromStages(Steps({"neighbourhoods", "outliers", "normals", "surface_spikes"}), loop)
          .ok());
}

TEST(Plan, AStepListedTwiceIsRefused) {
  const absl::StatusOr<Plan> twice =
      Plan::FromStages(Steps({"neighbourhoods", "normals", "normals"}), {});
  ASSERT_FALSE(twice.ok());
  EXPECT_EQ(twice.status().code(), absl::StatusCode::kFailedPrecondition);
}

// The steps a public stage expands to are not stages a job can list: options.stages is the API.
TEST(Plan, AnExpansionStepIsNotAStageAJobCanList) {
  EXPECT_EQ(ValidateOptions({.stages = {"surface_spikes"}}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(ValidateOptions({.stages = {"outliers"}}).ok());
}

// The report's stages are the plan's steps in the plan's order, for the default job and for LoOP,
// whose surface test runs on normals fitted after its removals: a step after "normals".
TEST(Plan, TheReportListsThePlansStepsInItsOrder) {
  const std::vector<std::pair<ParamOverrides, std::vector<std::string>>> cases = {
      {{},
       {"neighbourhoods", "normals", "outliers", "measures", "registration", "correction", "health",
        "smoothing", "simplification"}},
      {{{"outliers.method", "loop"}},
       {"neighbourhoods", "outliers", "normals", "surface_spikes", "measures", "registration",
        "correction", "health", "smoothing", "simplification"}},
  };
  for (const auto& [params, expected] : cases) {
    const absl::StatusOr<Plan> plan = Plan::Resolve(DefaultStages(), params);
    ASSERT_TRUE(plan.ok()) << plan.status();
    EXPECT_EQ(Names(plan->stages()), expected);

    auto sim = sim::SimulateWithPointCount(
        sim::Part::kPlane, sim::TwoOverlappingSensors(sim::Part::kPlane), 20'000, 0.01, 3);
    const CancelToken never;
    const absl::StatusOr<PipelineReport> report = RunPipeline(sim.cloud, {.params = params}, never);
    ASSERT_TRUE(report.ok()) << report.status();
    std::vector<std::string> ran;
    for (const StageReport& stage : report->stages) ran.push_back(stage.name);
    EXPECT_EQ(ran, expected);
  }
}

}  // namespace
}  // namespace scanprep
