// SPDX-License-Identifier: Apache-2.0
// The paper's 2σ nearest-neighbour rule on a regular grid with spikes displaced along the view.
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "tests/support/outliers_call.h"
#include "tests/support/test_data.h"

namespace scanprep {
namespace {

TEST(Outliers, RemovesSpikesAndKeepsTheGrid) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "grid", .scanline_spacing = 0.2});
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 0.01f);
  const int side = 200;  // 40,000 grid points at 0.2 mm
  std::vector<bool> is_spike;
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      cloud.x.push_back(col * 0.2f);
      cloud.y.push_back(row * 0.2f);
      cloud.z.push_back(noise(rng));
      cloud.scanline.push_back(row);
      is_spike.push_back(false);
    }
  }
  // 1 % spikes, 2-10 mm above the surface.
  std::uniform_real_distribution<float> height(2.f, 10.f), pos(0.f, side * 0.2f);
  for (int s = 0; s < side * side / 100; ++s) {
    cloud.x.push_back(pos(rng));
    cloud.y.push_back(pos(rng));
    cloud.z.push_back(height(rng));
    cloud.scanline.push_back(0);
    is_spike.push_back(true);
  }
  cloud.FinishLoading();

  auto report = testing::RunOutlierFunctions(cloud);
  ASSERT_TRUE(report.ok()) << report.status();

  size_t true_pos = 0, false_pos = 0, spikes = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    spikes += is_spike[i];
    if (cloud.flags[i] & kRemovedOutlier) (is_spike[i] ? true_pos : false_pos)++;
  }
  EXPECT_GE(true_pos, 0.95 * spikes);
  EXPECT_LE(false_pos, 0.001 * side * side);
  // The surface test pulls in the normals, listed before the stage that needed them.
  ASSERT_EQ(report->stages.size(), 3u);
  EXPECT_EQ(report->stages[0].name, "neighbourhoods");
  EXPECT_EQ(report->stages[1].name, "normals");
  const StageReport& stage = report->stages[2];
  EXPECT_EQ(stage.name, "outliers");
  EXPECT_EQ(stage.points_in, cloud.size());
  EXPECT_EQ(stage.points_out, cloud.size() - true_pos - false_pos);
  EXPECT_NEAR(stage.parameters.at("outliers.mean_d_mm"), 0.2, 0.02);
}

// Two scans of one 100×100 grid at 0.2 mm (the second offset by half a cell), and 50 spikes 2-10
// mm above it, each recorded twice by the first scan and once by the second at the same spot: a
// re-sent point, and the same stray reflection seen by both sensors. Neither copy may vouch for
// the other.
TEST(Outliers, DuplicatedSpikesAreCaught) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "a", .scanline_spacing = 0.2});
  cloud.scans.push_back(ScanMeta{.id = "b", .scanline_spacing = 0.2});
  std::vector<bool> is_spike;
  auto add = [&](float x, float y, float z, uint32_t scan, bool spike) {
    cloud.x.push_back(x);
    cloud.y.push_back(y);
    cloud.z.push_back(z);
    cloud.scan.push_back(scan);
    is_spike.push_back(spike);
  };
  for (uint32_t scan = 0; scan < 2; ++scan) {
    for (int row = 0; row < 100; ++row) {
      for (int col = 0; col < 100; ++col)
        add((col + 0.5f * scan) * 0.2f, row * 0.2f, 0, scan, false);
    }
  }
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> height(2.f, 10.f), pos(0.f, 20.f);
  for (int s = 0; s < 50; ++s) {
    const float x = pos(rng), y = pos(rng), z = height(rng);
    add(x, y, z, 0, true);
    add(x, y, z, 0, true);
    add(x, y, z, 1, true);
  }
  cloud.FinishLoading();
  // The job's path: the exact repeats are collapsed before the first stage (RunPipeline), which
  // is what lets a repeated spike be judged as one point.
  CancelToken cancel;
  auto report = RunPipeline(cloud, {.stages = {"outliers"}}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();
  size_t spikes_kept = 0, grid_removed = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const bool removed = (cloud.flags[i] & kRemovedOutlier) != 0;
    spikes_kept += is_spike[i] && !removed;
    grid_removed += !is_spike[i] && removed;
  }
  EXPECT_EQ(spikes_kept, 0u);
  EXPECT_EQ(grid_removed, 0u);
}

// A noiseless light-section grid whose far end is sampled 5 % wider (the last 10 of 100
// scanlines, both spacings 0.21 mm instead of 0.2 mm, as at the far end of a field of view):
// there is no outlier at all. σ of d_1 is then tiny, μ + 2σ ≈ 0.206 mm, and only the
// 1.5·median floor of §5 keeps the wider scanlines.
TEST(Outliers, SlightlyWiderScanlinesAreNoOutliers) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "grid", .scanline_spacing = 0.2});
  float y = 0;
  for (int row = 0; row < 100; ++row) {
    const float step = row < 90 ? 0.2f : 0.21f;
    if (row > 0) y += step;
    for (int col = 0; col < 100; ++col) {
      cloud.x.push_back(col * step);
      cloud.y.push_back(y);
      cloud.z.push_back(0);
      cloud.scanline.push_back(row);
    }
  }
  cloud.FinishLoading();
  // The paper's rule alone: the surface test would vouch for the wider rows whatever the floor.
  auto report = testing::RunOutlierFunctions(cloud, {{"outliers.surface_sigmas", "0"}});
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(cloud.CountKept(), cloud.size());
}

// Share of the points the outlier stage removes from `cloud`.
double RemovedShare(PointCloud cloud, ParamOverrides params = {}) {
  auto report = testing::RunOutlierFunctions(cloud, std::move(params));
  EXPECT_TRUE(report.ok()) << report.status();
  size_t removed = 0;
  for (size_t i = 0; i < cloud.size(); ++i) removed += (cloud.flags[i] & kRemovedOutlier) != 0;
  return static_cast<double>(removed) / cloud.size();
}

// Five real scans overlapping heavily (a 120° turntable sector): judged in one job, a point must
// be judged as in its own scan alone. Measured against the share removed when each scan is
// processed alone, the ground truth of what each scan's own statistics call an outlier.
TEST(Outliers, OverlappingScansLoseNoMoreThanEachScanAlone) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  const std::vector<std::string> names = {"happyStandRight_264", "happyStandRight_288",
                                          "happyStandRight_312", "happyStandRight_336",
                                          "happyStandRight_24"};
  const auto dir = data / "stanford_happy_stand_range_scans";
  // Neighbour spacing about 0.38 mm along and between rows (data README).
  const PointCloud all = testing::LoadRangeScansMm(dir, "happyStandRight.conf", names, 0.38);
  ASSERT_EQ(all.size(), 366'479u);
  // With the surface test (default) and with the paper's d_1 rule alone, whose own-scan d_1 is
  // what keeps overlaps right when no plane vouches for a point.
  for (const ParamOverrides& params : {ParamOverrides{}, {{"outliers.surface_sigmas", "0"}}}) {
    size_t alone_removed = 0;
    for (const std::string& name : names) {
      const PointCloud one = testing::LoadRangeScansMm(dir, "happyStandRight.conf", {name}, 0.38);
      alone_removed += static_cast<size_t>(std::lround(RemovedShare(one, params) * one.size()));
    }
    const double alone = static_cast<double>(alone_removed) / all.size();
    const double together = RemovedShare(all, params);
    std::printf("removed as outliers%s: %.3f %% one scan at a time, %.3f %% in one job\n",
                params.empty() ? "" : " (d_1 rule alone)", 100 * alone, 100 * together);
    EXPECT_GT(alone, 0.001);  // the scans have real outliers to find
    EXPECT_LE(together, 1.5 * alone);
    EXPECT_GE(together, alone / 1.5);
  }
}

struct Score {
  double precision, recall, removed_share;
};

// Precision and recall of the outlier stage against the simulator's spike labels.
Score ScoreOutliers(const sim::SimulatedCloud& sim, ParamOverrides params) {
  PointCloud cloud = sim.cloud;
  auto report = testing::RunOutlierFunctions(cloud, std::move(params));
  EXPECT_TRUE(report.ok()) << report.status();
  size_t true_pos = 0, removed = 0, spikes = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const bool out = (cloud.flags[i] & kRemovedOutlier) != 0;
    spikes += sim.is_outlier[i];
    removed += out;
    true_pos += out && sim.is_outlier[i];
  }
  return {removed > 0 ? double(true_pos) / removed : 1.0,
          spikes > 0 ? double(true_pos) / spikes : 1.0, double(removed) / cloud.size()};
}

// Laser-line spikes 5-20 σ along the viewing ray have nearest neighbours as close as any grid
// point: the d_1 rule alone (control) finds under half; judged by their offset from the planes
// their neighbours support, nearly all, with few good points taken.
TEST(Outliers, SpikesAFewSigmaOffTheSurfaceAreCaught) {
  auto sensors = sim::FrontalSensor(sim::Part::kBoxWithBore);
  sensors[0].outlier_fraction = 0.005;
  const auto sim = sim::Simulate(sim::Part::kBoxWithBore, sensors, 21);
  const Score both = ScoreOutliers(sim, {});
  const Score d1_only = ScoreOutliers(sim, {{"outliers.surface_sigmas", "0"}});
  std::printf("box spikes: precision %.3f recall %.3f; d_1 rule alone %.3f / %.3f\n",
              both.precision, both.recall, d1_only.precision, d1_only.recall);
  EXPECT_GE(both.recall, 0.95);
  EXPECT_GE(both.precision, 0.8);
  EXPECT_LT(d1_only.recall, 0.6);
}

// The box's side faces meet the scanner obliquely: its grid is sparser there, and one threshold
// per scan (control: the d_1 rule alone) takes their ordinary points. A point beyond the
// threshold that lies on a plane its neighbours support stays.
TEST(Outliers, SparseObliqueFacesKeepTheirPoints) {
  const auto sim =
      sim::Simulate(sim::Part::kBoxWithBore, sim::FrontalSensor(sim::Part::kBoxWithBore), 22);
  const Score both = ScoreOutliers(sim, {});
  const Score d1_only = ScoreOutliers(sim, {{"outliers.surface_sigmas", "0"}});
  std::printf("spike-free box: removed %.3f %%, d_1 rule alone %.3f %%\n", 100 * both.removed_share,
              100 * d1_only.removed_share);
  EXPECT_LT(both.removed_share, 0.002);
  EXPECT_GT(d1_only.removed_share, 0.04);
}

TEST(Outliers, CancelledJobStops) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "a"});
  for (int i = 0; i < 5000; ++i) {
    cloud.x.push_back(i * 0.1f);
    cloud.y.push_back(0);
    cloud.z.push_back(0);
  }
  cloud.FinishLoading();
  CancelToken cancel;
  cancel.Cancel();
  auto report = RunPipeline(cloud, {}, cancel);
  EXPECT_EQ(report.status().code(), absl::StatusCode::kCancelled);
}

TEST(Pipeline, RejectsUnknownStageAndParameter) {
  EXPECT_EQ(ValidateOptions({.stages = {"sharpen"}}).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ValidateOptions({.params = {{"outliers.nope", "1"}}}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ValidateOptions({.params = {{"outliers.multiplier", "abc"}}}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(ValidateOptions({.params = {{"outliers.multiplier", "3"}}}).ok());
}

}  // namespace
}  // namespace scanprep
