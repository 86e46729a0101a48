// SPDX-License-Identifier: Apache-2.0
// The default pipeline (outliers → correction → smoothing → simplification) end to end: on the
// simulator with two overlapping scans and spikes, and on the ten registered Stanford bunny scans.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "tests/support/kdtree.h"
#include "tests/support/test_data.h"

namespace scanprep {
namespace {

namespace fs = std::filesystem;
using sim::Part;

const StageReport* FindReport(const PipelineReport& report, const std::string& name) {
  for (const StageReport& stage : report.stages) {
    if (stage.name == name) return &stage;
  }
  return nullptr;
}

void PrintReport(const PipelineReport& report) {
  for (const StageReport& stage : report.stages) {
    std::printf("  %-15s %8llu -> %8llu points  %6.2f s\n", stage.name.c_str(),
                static_cast<unsigned long long>(stage.points_in),
                static_cast<unsigned long long>(stage.points_out), stage.seconds);
  }
}

// Every numeric parameter a stage declares is in its report, plain or per scan.
void ExpectParametersReported(const PipelineReport& report, const std::string& stage_name) {
  const StageReport* stage = FindReport(report, stage_name);
  ASSERT_NE(stage, nullptr) << stage_name;
  for (const ParamSpec& spec : FindOfferedStage(stage_name)->params) {
    if (!spec.choices.empty()) continue;
    EXPECT_TRUE(stage->parameters.contains(spec.name) ||
                stage->parameters.contains(spec.name + ".scan0"))
        << spec.name;
  }
}

TEST(Pipeline, DefaultStagesRunOnTwoOverlappingScansWithSpikes) {
  std::vector<sim::SimSensor> sensors = sim::TwoOverlappingSensors(Part::kBoxWithBore);
  for (sim::SimSensor& s : sensors) s.outlier_fraction = 0.01;
  auto sim = sim::Simulate(Part::kBoxWithBore, sensors, 41);
  PointCloud& cloud = sim.cloud;
  CancelToken cancel;
  auto report = RunPipeline(cloud, {}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();
  PrintReport(*report);

  for (const char* name : {"correction", "smoothing", "simplification"}) {
    ExpectParametersReported(*report, name);
  }
  size_t spikes = 0, spikes_kept = 0, merged = 0, simplified = 0, smoothed = 0;
  double rms = 0;
  size_t kept = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    spikes += sim.is_outlier[i];
    spikes_kept += sim.is_outlier[i] && !cloud.removed(i);
    merged += (cloud.flags[i] & kRemovedMerge) != 0;
    simplified += (cloud.flags[i] & kRemovedSimplify) != 0;
    smoothed += (cloud.flags[i] & kSmoothed) != 0;
    if (cloud.removed(i) || sim.is_outlier[i]) continue;
    const double d = sim::DistanceToSurface(Part::kBoxWithBore, cloud.point(i).cast<double>());
    rms += d * d;
    ++kept;
  }
  rms = std::sqrt(rms / kept);
  std::printf(
      "spikes %zu (kept %zu), merged away %zu, smoothed %zu, simplified away %zu, "
      "kept %zu of %zu, RMS of kept non-spikes %.4f mm\n",
      spikes, spikes_kept, merged, smoothed, simplified, cloud.CountKept(), cloud.size(), rms);
  EXPECT_LE(spikes_kept, spikes / 4);
  EXPECT_GT(merged, cloud.size() / 20);
  EXPECT_GT(smoothed, cloud.size() / 2);
  EXPECT_GT(simplified, cloud.size() / 4);
  EXPECT_LT(rms, 0.02);
  EXPECT_EQ(report->stages.back().name, "simplification");
}

const std::vector<std::string> kBunnyScans = {"bun000", "bun045", "bun090", "bun180",   "bun270",
                                              "bun315", "chin",   "top2",   "ear_back", "top3"};

// The ten scans in the common frame, in mm; rows of the range grid are scanlines, 0.82 mm apart
// (measured, data README).
PointCloud LoadBunnyMm(const fs::path& dir) {
  return testing::LoadRangeScansMm(dir, "bun.conf", kBunnyScans, 0.82);
}

// Share of the selected points that have a point of another scan closer than their own scan's
// point spacing: how much of the cloud is still a double layer.
template <typename Select>
double DoubleLayerShare(const PointCloud& cloud, const std::vector<double>& spacing,
                        Select select) {
  PointCloud chosen;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!select(i)) continue;
    chosen.x.push_back(cloud.x[i]);
    chosen.y.push_back(cloud.y[i]);
    chosen.z.push_back(cloud.z[i]);
    chosen.scan.push_back(cloud.scan[i]);
  }
  const KdTree tree(chosen);
  constexpr size_t kProbe = 16;
  size_t doubled = 0;
  std::vector<uint32_t> idx(kProbe);
  std::vector<float> d2(kProbe);
  for (size_t i = 0; i < chosen.size(); ++i) {
    const float q[3] = {chosen.x[i], chosen.y[i], chosen.z[i]};
    const size_t found = tree.Knn(q, kProbe, idx.data(), d2.data());
    const double limit = spacing[chosen.scan[i]];
    for (size_t j = 0; j < found && d2[j] < limit * limit; ++j) {
      if (chosen.scan[idx[j]] != chosen.scan[i]) {
        ++doubled;
        break;
      }
    }
  }
  return chosen.size() ? double(doubled) / chosen.size() : 0.0;
}

TEST(Pipeline, BunnyTenScansThroughTheDefaultPipeline) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  PointCloud cloud = LoadBunnyMm(data / "stanford_bunny_range_scans");
  ASSERT_EQ(cloud.size(), 362'272u);
  CancelToken cancel;
  auto report = RunPipeline(cloud, {}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();
  PrintReport(*report);
  const StageReport* measures = FindReport(*report, "measures");
  ASSERT_NE(measures, nullptr);
  std::vector<double> spacing;
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    spacing.push_back(measures->parameters.at(absl::StrCat("measures.point_spacing_mm.scan", s)));
  }
  const double before = DoubleLayerShare(
      cloud, spacing, [&](size_t i) { return !(cloud.flags[i] & kRemovedOutlier); });
  const double after_correction = DoubleLayerShare(cloud, spacing, [&](size_t i) {
    return !(cloud.flags[i] & (kRemovedOutlier | kRemovedMerge));
  });
  const double final_share =
      DoubleLayerShare(cloud, spacing, [&](size_t i) { return !cloud.removed(i); });
  const StageReport* correction = FindReport(*report, "correction");
  const StageReport* simplification = FindReport(*report, "simplification");
  ASSERT_NE(correction, nullptr);
  ASSERT_NE(simplification, nullptr);
  std::printf(
      "bunny: Δp scan0 %.3f mm, r_c scan0 %.3f mm, %g gather rounds, r_s %.3f mm; "
      "double-layer share %.1f %% before correction, %.1f %% after, %.1f %% after "
      "simplification; %zu of %zu points kept\n",
      spacing[0], correction->parameters.at("correction.radius_mm.scan0"),
      correction->parameters.at("correction.rounds_run"),
      simplification->parameters.at("simplification.spacing_mm"), 100 * before,
      100 * after_correction, 100 * final_share, cloud.CountKept(), cloud.size());
  EXPECT_GT(before, 0.3);
  EXPECT_LT(after_correction, 0.25 * before);
  EXPECT_GT(correction->parameters.at("correction.removed"), 0.2 * cloud.size());
  for (const char* name : {"correction", "smoothing", "simplification"}) {
    ExpectParametersReported(*report, name);
  }
}

}  // namespace
}  // namespace scanprep
