// SPDX-License-Identifier: Apache-2.0
// Progress a person can follow: the stages in the order they run (prerequisites first, as the
// plan says), each reporting progress inside it, and one job fraction that never goes back and
// ends at 1.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/pipeline/plan.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

struct Seen {
  std::string stage;
  size_t index, count;
  double stage_fraction, job_fraction;
};

std::vector<Seen> RunAndWatch(PointCloud& cloud, const PipelineOptions& options) {
  std::vector<Seen> seen;
  CancelToken cancel;
  auto report = RunPipeline(cloud, options, cancel, [&](const ProgressEvent& e) {
    seen.push_back(
        {std::string(e.stage), e.stage_index, e.stage_count, e.stage_fraction, e.job_fraction});
  });
  EXPECT_TRUE(report.ok()) << report.status();
  // The report lists the stages as they ran: the same order as the events.
  std::vector<std::string> ran, announced;
  for (const StageReport& s : report->stages) ran.push_back(s.name);
  for (const Seen& s : seen) {
    if (announced.empty() || announced.back() != s.stage) announced.push_back(s.stage);
  }
  EXPECT_EQ(announced, ran);
  return seen;
}

TEST(Progress, DefaultPipelineReportsEveryStageInPlanOrderWithProgressInside) {
  auto sim = sim::SimulateWithPointCount(sim::Part::kBoxWithBore,
                                         sim::TwoOverlappingSensors(sim::Part::kBoxWithBore),
                                         300'000, 0.01, 7);
  const std::vector<Seen> seen = RunAndWatch(sim.cloud, {});
  const std::vector<std::string> plan = {"neighbourhoods", "normals",      "outliers",
                                         "measures",       "registration", "correction",
                                         "health",         "smoothing",    "simplification"};
  ASSERT_FALSE(seen.empty());
  std::vector<int> inside(plan.size(), 0);
  double job = 0;
  size_t index = 0;
  for (const Seen& s : seen) {
    ASSERT_EQ(s.count, plan.size());
    ASSERT_LT(s.index, plan.size());
    EXPECT_EQ(s.stage, plan[s.index]);
    EXPECT_GE(s.index, index) << s.stage;
    EXPECT_GE(s.job_fraction, job) << s.stage << " " << s.stage_fraction;
    EXPECT_GE(s.stage_fraction, 0);
    EXPECT_LE(s.stage_fraction, 1);
    index = s.index, job = s.job_fraction;
    if (s.stage_fraction > 0 && s.stage_fraction < 1) ++inside[s.index];
  }
  for (size_t i = 0; i < plan.size(); ++i) EXPECT_GT(inside[i], 0) << plan[i];
  EXPECT_DOUBLE_EQ(seen.back().job_fraction, 1.0);
  EXPECT_DOUBLE_EQ(seen.back().stage_fraction, 1.0);
}

// The plan follows the parameters: without the surface test the outlier stage needs no normals,
// so it runs right after the neighbourhoods and the normals come with the measures.
TEST(Progress, ThePlanFollowsTheParameters) {
  auto sim = sim::SimulateWithPointCount(
      sim::Part::kPlane, sim::TwoOverlappingSensors(sim::Part::kPlane), 20'000, 0.01, 3);
  const std::vector<Seen> seen =
      RunAndWatch(sim.cloud, {.params = {{"outliers.surface_sigmas", "0"}}});
  std::vector<std::string> order;
  for (const Seen& s : seen) {
    if (order.empty() || order.back() != s.stage) order.push_back(s.stage);
  }
  EXPECT_EQ(order, (std::vector<std::string>{"neighbourhoods", "outliers", "normals", "measures",
                                             "registration", "correction", "health", "smoothing",
                                             "simplification"}));
}

// Every stage's plan: it comes last, each prerequisite before the stage that needs it, every stage
// once, neighbourhoods first. (A cycle would never return.)
TEST(Progress, EveryStagesPlanPutsPrerequisitesFirst) {
  const ParamOverrides none;
  for (const StageInfo& info : StageRegistry()) {
    const absl::StatusOr<Plan> planned = Plan::Resolve({info.name}, none);
    ASSERT_TRUE(planned.ok()) << planned.status();
    const std::vector<const StageInfo*>& plan = planned->stages();
    ASSERT_FALSE(plan.empty());
    EXPECT_EQ(plan.back(), &info);
    EXPECT_EQ(plan.front()->name, "neighbourhoods") << info.name;
    for (size_t i = 0; i < plan.size(); ++i) {
      for (size_t j = i + 1; j < plan.size(); ++j) EXPECT_NE(plan[i], plan[j]) << info.name;
      if (!plan[i]->prerequisites) continue;
      for (const std::string& need : plan[i]->prerequisites(none)) {
        const auto at = std::find_if(plan.begin(), plan.begin() + i,
                                     [&](const StageInfo* s) { return s->name == need; });
        EXPECT_NE(at, plan.begin() + i) << need << " after " << plan[i]->name;
      }
    }
  }
}

}  // namespace
}  // namespace scanprep
