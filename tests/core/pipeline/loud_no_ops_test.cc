// SPDX-License-Identifier: Apache-2.0
// A stage that cannot do its job for want of metadata says so: a warning in the report and a
// machine-readable record, each path tested against a control that has the metadata, where the
// record reads 0 and the warning is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <string_view>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

using sim::Part;

struct StageRun {
  PipelineReport report;
  bool Warned(std::string_view text) const {
    return std::any_of(report.warnings.begin(), report.warnings.end(),
                       [&](const Warning& w) { return w.message.find(text) != std::string::npos; });
  }
  double Record(std::string_view stage, const std::string& name) const {
    for (const StageReport& s : report.stages) {
      if (s.name != stage) continue;
      auto it = s.parameters.find(name);
      EXPECT_NE(it, s.parameters.end()) << name;
      return it == s.parameters.end() ? -1 : it->second;
    }
    ADD_FAILURE() << "stage " << stage << " did not run";
    return -1;
  }
};

StageRun RunStages(PointCloud cloud, std::vector<std::string> stages) {
  CancelToken cancel;
  auto report = RunPipeline(cloud, {.stages = std::move(stages)}, cancel);
  EXPECT_TRUE(report.ok()) << report.status();
  return {report.ok() ? *std::move(report) : PipelineReport{}};
}

// One frontal laser-line scan of a plane: poses, spacing, u and scanlines all present.
PointCloud OneScan() {
  return sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 41).cloud;
}

void ForgetPoses(PointCloud& cloud) {
  for (ScanMeta& scan : cloud.scans) {
    scan.camera_position.reset();
    scan.view_direction.reset();
    scan.projector_position.reset();
    scan.projector_direction.reset();
  }
}

TEST(LoudNoOps, CorrectionOfASingleScanSaysThereIsNothingToMerge) {
  const StageRun one = RunStages(OneScan(), {"correction"});
  EXPECT_EQ(one.Record("correction", "correction.single_scan"), 1);
  EXPECT_TRUE(one.Warned("correction: the job has one scan"));

  const StageRun two =
      RunStages(sim::Simulate(Part::kPlane, sim::TwoOverlappingSensors(Part::kPlane), 41).cloud,
                {"correction"});
  EXPECT_EQ(two.Record("correction", "correction.single_scan"), 0);
  EXPECT_FALSE(two.Warned("correction: the job has one scan"));
}

TEST(LoudNoOps, LineScanWithoutScanlineSpacingLosesEq2sSpacingTerm) {
  PointCloud cloud = OneScan();
  cloud.scans[0].scanline_spacing = 0;
  const StageRun without = RunStages(cloud, {"neighbourhoods"});
  EXPECT_EQ(without.Record("neighbourhoods", "neighbourhoods.scans_without_spacing"), 1);
  EXPECT_TRUE(without.Warned("state no scanline spacing"));

  const StageRun with = RunStages(OneScan(), {"neighbourhoods"});
  EXPECT_EQ(with.Record("neighbourhoods", "neighbourhoods.scans_without_spacing"), 0);
  EXPECT_FALSE(with.Warned("state no scanline spacing"));
}

TEST(LoudNoOps, FlexibleScannerWithoutSpacingIsNotADegradation) {
  PointCloud cloud = OneScan();
  cloud.kind = ScannerKind::kFlexible;
  cloud.scans[0].scanline_spacing = 0;
  cloud.scanline.clear();
  const StageRun run = RunStages(cloud, {"measures"});
  EXPECT_EQ(run.Record("neighbourhoods", "neighbourhoods.scans_without_spacing"), 0);
  EXPECT_EQ(run.Record("measures", "measures.line_scan_without_scanlines"), 0);
  EXPECT_FALSE(run.Warned("scanline"));
}

TEST(LoudNoOps, DefaultUncertaintyIsNamed) {
  PointCloud cloud = OneScan();
  cloud.scans[0].uncertainty_stated = false;
  const StageRun without = RunStages(cloud, {"neighbourhoods"});
  EXPECT_EQ(without.Record("neighbourhoods", "neighbourhoods.scans_default_uncertainty"), 1);
  EXPECT_TRUE(without.Warned("state no measuring uncertainty u; the default 0.1 mm"));

  const StageRun with = RunStages(OneScan(), {"neighbourhoods"});
  EXPECT_EQ(with.Record("neighbourhoods", "neighbourhoods.scans_default_uncertainty"), 0);
  EXPECT_FALSE(with.Warned("measuring uncertainty"));
}

TEST(LoudNoOps, ViewingQualityWithoutPosesIsCounted) {
  PointCloud cloud = OneScan();
  ForgetPoses(cloud);
  const StageRun without = RunStages(cloud, {"measures"});
  EXPECT_EQ(without.Record("measures", "measures.scans_without_pose"), 1);
  EXPECT_TRUE(without.Warned("has neither sensor poses nor a per-point quality"));

  const StageRun with = RunStages(OneScan(), {"measures"});
  EXPECT_EQ(with.Record("measures", "measures.scans_without_pose"), 0);
  EXPECT_FALSE(with.Warned("neither sensor poses"));
}

TEST(LoudNoOps, LineScanWithoutScanlinesFallsBackToSurfaceVariationLoudly) {
  PointCloud cloud = OneScan();
  cloud.scanline.clear();
  const StageRun without = RunStages(cloud, {"measures"});
  EXPECT_EQ(without.Record("measures", "measures.line_scan_without_scanlines"), 1);
  EXPECT_TRUE(without.Warned("came without scanline indices"));

  const StageRun with = RunStages(OneScan(), {"measures"});
  EXPECT_EQ(with.Record("measures", "measures.line_scan_without_scanlines"), 0);
  EXPECT_FALSE(with.Warned("scanline indices"));
}

TEST(LoudNoOps, NormalsWithoutASensorAreOrientedByTheTreeAndSaySo) {
  PointCloud cloud = OneScan();
  ForgetPoses(cloud);
  const StageRun without = RunStages(cloud, {"normals"});
  EXPECT_GT(without.Record("normals", "normals.oriented_by_tree"), 0);
  EXPECT_TRUE(without.Warned("oriented by spanning-tree propagation (no sensor pose)"));

  const StageRun with = RunStages(OneScan(), {"normals"});
  EXPECT_EQ(with.Record("normals", "normals.oriented_by_tree"), 0);
  EXPECT_FALSE(with.Warned("spanning-tree"));
}

TEST(LoudNoOps, SmoothingWithoutPosesWeighsByFlatnessAloneAndSaysSo) {
  PointCloud blind = OneScan();
  ForgetPoses(blind);
  const StageRun without = RunStages(std::move(blind), {"smoothing"});
  EXPECT_EQ(without.Record("smoothing", "smoothing.without_quality"), 1);
  EXPECT_TRUE(without.Warned("smoothing: every point has the same viewing quality"));
  const StageRun with = RunStages(OneScan(), {"smoothing"});
  EXPECT_EQ(with.Record("smoothing", "smoothing.without_quality"), 0);
  EXPECT_FALSE(with.Warned("smoothing: every point has the same viewing quality"));
}

// The paper's rule δ = u with no u stated: δ is the 0.1 mm default. The default method measures
// the noise, so it has nothing to say (control), nor does a stated u.
TEST(LoudNoOps, PaperSmoothingWithTheDefaultUncertaintySaysSo) {
  auto run = [](bool stated, const char* method) {
    PointCloud cloud = OneScan();
    cloud.scans[0].uncertainty_stated = stated;
    CancelToken cancel;
    auto report = RunPipeline(
        cloud, {.stages = {"smoothing"}, .params = {{"smoothing.method", method}}}, cancel);
    EXPECT_TRUE(report.ok()) << report.status();
    return StageRun{report.ok() ? *std::move(report) : PipelineReport{}};
  };
  const StageRun unstated = run(false, "mean");
  EXPECT_EQ(unstated.Record("smoothing", "smoothing.tolerance_from_default_u"), 1);
  EXPECT_TRUE(unstated.Warned("states no uncertainty; δ is the default"));
  for (const StageRun& control : {run(true, "mean"), run(false, "own_side")}) {
    EXPECT_EQ(control.Record("smoothing", "smoothing.tolerance_from_default_u"), 0);
    EXPECT_FALSE(control.Warned("states no uncertainty; δ is the default"));
  }
}

TEST(LoudNoOps, SimplificationWithoutAScannerPitchUsesTheDensityAndSaysSo) {
  PointCloud flexible = OneScan();
  flexible.kind = ScannerKind::kFlexible;  // no scanline spacing counts
  const StageRun without = RunStages(std::move(flexible), {"simplification"});
  EXPECT_EQ(without.Record("simplification", "simplification.spacing_from_density"), 1);
  EXPECT_TRUE(without.Warned("derived from the cloud's density"));
  const StageRun with = RunStages(OneScan(), {"simplification"});
  EXPECT_EQ(with.Record("simplification", "simplification.spacing_from_density"), 0);
  EXPECT_FALSE(with.Warned("derived from the cloud's density"));
}

}  // namespace
}  // namespace scanprep
