// SPDX-License-Identifier: Apache-2.0
// UNIT_SUSPECT from the data: a scan whose coordinates are in another unit than the job states
// (a file in metres sent as millimetres) has its points and noise 1000x closer than its stated
// spacing and uncertainty say. Controls: the same scans in the right unit, and a scan that
// states nothing. And options.fail_on: the job stops at the end of the stage that warned.
#include <algorithm>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"

#include "core/pipeline/pipeline.h"
#include "core/stages/warning.h"
#include "tests/support/metrology_job.h"
#include "tests/support/normals_call.h"
#include "tests/support/test_data.h"

namespace scanprep {
namespace {

constexpr size_t kPoints = 30'000;
constexpr uint64_t kSeed = 29;

PointCloud Scaled(PointCloud cloud, float factor) {
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud.x[i] *= factor, cloud.y[i] *= factor, cloud.z[i] *= factor;
  }
  return cloud;
}

// The UNIT_SUSPECT warnings of the normals stage's function, which judges the unit once its fits
// have measured the noise.
std::vector<Warning> UnitWarnings(PointCloud cloud) {
  auto report = testing::RunNormalsFunction(cloud);
  EXPECT_TRUE(report.ok()) << report.status();
  std::vector<Warning> found;
  if (!report.ok()) return found;
  for (const Warning& w : report->warnings) {
    if (w.code == WarningCode::kUnitSuspect) found.push_back(w);
  }
  return found;
}

double Param(const Warning& w, const std::string& key) {
  auto it = w.params.find(key);
  EXPECT_NE(it, w.params.end()) << key;
  return it == w.params.end() ? 0 : std::stod(it->second);
}

const sim::SimulatedCloud& Simulated() {
  static const sim::SimulatedCloud sim = testing::SimulateEvaluationScan(kPoints, kSeed);
  return sim;
}

TEST(UnitPlausibility, SimulatedScansInTheirStatedUnitAreNotSuspect) {
  EXPECT_TRUE(UnitWarnings(testing::WithUserMetadata(Simulated())).empty());
}

TEST(UnitPlausibility, MetresSentAsMillimetresAreSuspectWithTheNumbers) {
  const PointCloud mm = testing::WithUserMetadata(Simulated());
  const std::vector<Warning> found = UnitWarnings(Scaled(mm, 1e-3f));
  ASSERT_EQ(found.size(), mm.scans.size()) << "one per scan";
  for (const Warning& w : found) {
    EXPECT_NE(w.message.find("smaller"), std::string::npos) << w.message;
    // Ground truth: the simulator's spacing and σ, stated in mm, against data 1000x smaller.
    const double stated_spacing = Param(w, "stated_spacing_mm");
    EXPECT_LT(Param(w, "measured_spacing_mm"), stated_spacing * 3e-3);
    EXPECT_GT(Param(w, "measured_spacing_mm"), stated_spacing * 1e-4);
    EXPECT_DOUBLE_EQ(Param(w, "stated_uncertainty_mm"), testing::kEvaluationSigmaMm);
    EXPECT_LT(Param(w, "measured_noise_mm"), testing::kEvaluationSigmaMm * 3e-3);
  }
}

// Every simulated part as the simulator states it (spacing, u = its conservative 3σ, poses).
TEST(UnitPlausibility, EverySimulatedPartIsJudgedRightInMillimetresAndSuspectInMetres) {
  for (const sim::Part part : {sim::Part::kPlane, sim::Part::kSphere, sim::Part::kCylinder,
                               sim::Part::kBoxWithBore, sim::Part::kSteppedBlock}) {
    SCOPED_TRACE(static_cast<int>(part));
    const PointCloud mm = sim::Simulate(part, sim::ThreeOverlappingSensors(part), kSeed).cloud;
    EXPECT_TRUE(UnitWarnings(mm).empty());
    EXPECT_EQ(UnitWarnings(Scaled(mm, 1e-3f)).size(), mm.scans.size());
  }
}

TEST(UnitPlausibility, MillimetresSentAsMetresAreSuspectToo) {
  const std::vector<Warning> found =
      UnitWarnings(Scaled(testing::WithUserMetadata(Simulated()), 1e3f));
  ASSERT_FALSE(found.empty());
  EXPECT_NE(found.front().message.find("larger"), std::string::npos) << found.front().message;
}

// ...but says so (UNIT_UNCHECKED, which strict fails on), naming the scan and what to state;
// the control, every scan stating its scales, is checked and gets no such warning.
TEST(UnitPlausibility, AScanThatStatesNothingIsNotJudgedAndSaysSo) {
  PointCloud bare = testing::WithoutMetadata(Simulated());
  bare.scans[0].uncertainty_stated = false;  // as the server reads a header without u
  EXPECT_TRUE(UnitWarnings(Scaled(bare, 1e-3f)).empty());
  PointCloud scaled = Scaled(bare, 1e-3f);
  auto report = testing::RunNormalsFunction(scaled);
  ASSERT_TRUE(report.ok()) << report.status();
  const auto unchecked =
      std::find_if(report->warnings.begin(), report->warnings.end(),
                   [](const Warning& w) { return w.code == WarningCode::kUnitUnchecked; });
  ASSERT_NE(unchecked, report->warnings.end());
  EXPECT_EQ(unchecked->params.at("scans_unchecked"), "1");
  EXPECT_EQ(unchecked->params.at("first_scans"), "'" + bare.scans[0].id + "'");
  EXPECT_NE(unchecked->message.find("state one for the job's unit to be judged"),
            std::string::npos);
  EXPECT_NE(std::find(StrictWarningCodes().begin(), StrictWarningCodes().end(),
                      WarningCode::kUnitUnchecked),
            StrictWarningCodes().end());

  PointCloud with_metadata = testing::WithUserMetadata(Simulated());
  auto stated = testing::RunNormalsFunction(with_metadata);
  ASSERT_TRUE(stated.ok()) << stated.status();
  for (const Warning& w : stated->warnings)
    EXPECT_NE(w.code, WarningCode::kUnitUnchecked) << w.message;
}

TEST(UnitPlausibility, RealScansAreJudgedRightAndTheBunnyInTheWrongUnitSuspect) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  // The Cyberware's scanline spacing (0.82 mm) and u = 0.1 mm, as pipeline_test states them.
  const PointCloud mm = testing::LoadRangeScansMm(data / "stanford_bunny_range_scans", "bun.conf",
                                                  {"bun000", "bun045"}, 0.82);
  ASSERT_EQ(mm.scans.size(), 2u);
  EXPECT_TRUE(UnitWarnings(mm).empty()) << "control: the right unit";
  EXPECT_EQ(UnitWarnings(Scaled(mm, 1e-3f)).size(), 2u) << "the file's metres read as mm";
  // The Happy Buddha's scans (0.38 mm, as outliers_test states them): the right unit only.
  const PointCloud buddha =
      testing::LoadRangeScansMm(data / "stanford_happy_stand_range_scans", "happyStandRight.conf",
                                {"happyStandRight_24", "happyStandRight_264", "happyStandRight_288",
                                 "happyStandRight_312", "happyStandRight_336"},
                                0.38);
  ASSERT_EQ(buddha.scans.size(), 5u);
  EXPECT_TRUE(UnitWarnings(buddha).empty());
}

TEST(FailOn, AJobFailsAtTheEndOfTheStageThatWarnedAndRunsNoLaterStage) {
  PointCloud cloud = Scaled(testing::WithUserMetadata(Simulated()), 1e-3f);
  PipelineOptions options;
  options.fail_on = {WarningCode::kUnitSuspect};
  std::set<std::string> started;
  auto report = RunPipeline(cloud, options, CancelToken(),
                            [&](const ProgressEvent& e) { started.insert(std::string(e.stage)); });
  ASSERT_EQ(report.status().code(), absl::StatusCode::kFailedPrecondition) << report.status();
  const std::optional<Warning> failed = FailedWarning(report.status());
  ASSERT_TRUE(failed.has_value());
  EXPECT_EQ(failed->code, WarningCode::kUnitSuspect);
  EXPECT_EQ(WarningCodeName(failed->code), "UNIT_SUSPECT");
  EXPECT_TRUE(failed->params.contains("measured_spacing_mm"));
  EXPECT_TRUE(started.contains("normals"));  // UNIT_SUSPECT is judged there
  EXPECT_FALSE(started.contains("outliers"));
  EXPECT_FALSE(started.contains("smoothing"));

  // Control: the same job in its stated unit runs every stage.
  PointCloud right = testing::WithUserMetadata(Simulated());
  auto ok = RunPipeline(right, options, CancelToken());
  EXPECT_TRUE(ok.ok()) << ok.status();
}

// (Not SCAN_REPEATED as the code failed on: with the unit slipped, the simulated sensors, which
// sample the same lines, agree a hundred times better than their stated u, and that is named.)
TEST(FailOn, AWarningNotFailedOnStaysAWarning) {
  PointCloud cloud = Scaled(testing::WithUserMetadata(Simulated()), 1e-3f);
  PipelineOptions options;
  options.stages = {"normals"};
  options.fail_on = {WarningCode::kNoiseAboveUncertainty};
  auto report = RunPipeline(cloud, options, CancelToken());
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(std::any_of(report->warnings.begin(), report->warnings.end(),
                          [](const Warning& w) { return w.code == WarningCode::kUnitSuspect; }));
}

// Issue 39 finding 8: a report lists at most kMaxWarningsPerCode warnings of a code; the rest of
// that code fold into one that counts them and quotes the first, and other codes keep theirs.
TEST(WarningCodes, ARepeatedCodeIsListedTenTimesAndTheRestCounted) {
  std::vector<Warning> warnings;
  for (int s = 0; s < 25; ++s) {
    warnings.push_back({WarningCode::kNoPose, absl::StrCat("scan ", s, " has no pose")});
    if (s < 2) warnings.push_back({WarningCode::kUnitSuspect, absl::StrCat("unit ", s)});
  }
  FoldRepeatedWarnings(warnings);
  ASSERT_EQ(warnings.size(), kMaxWarningsPerCode + 2 + 1);
  size_t no_pose = 0;
  for (const Warning& w : warnings) no_pose += w.code == WarningCode::kNoPose;
  EXPECT_EQ(no_pose, kMaxWarningsPerCode + 1);
  const Warning& folded = warnings.back();
  EXPECT_EQ(folded.code, WarningCode::kNoPose);
  EXPECT_EQ(folded.params.at("warnings_left_out"), "15");
  EXPECT_NE(folded.message.find("15 more NO_POSE warnings"), std::string::npos) << folded.message;
  EXPECT_NE(folded.message.find("scan 10 has no pose"), std::string::npos) << folded.message;
}

TEST(WarningCodes, EveryCodeHasAUniqueNameThatMapsBack) {
  std::set<std::string_view> names;
  for (WarningCode code : AllWarningCodes()) {
    const std::string_view name = WarningCodeName(code);
    EXPECT_TRUE(names.insert(name).second) << name;
    EXPECT_EQ(WarningCodeFromName(name), code) << name;
  }
  EXPECT_FALSE(WarningCodeFromName("UNSPECIFIED").has_value());
  for (WarningCode code : StrictWarningCodes()) {
    EXPECT_TRUE(names.contains(WarningCodeName(code)));
  }
}

}  // namespace
}  // namespace scanprep
