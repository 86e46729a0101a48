// The paper's 2σ nearest-neighbour rule on a regular grid with spikes displaced along the view.
#include <random>

#include <gtest/gtest.h>

#include "core/pipeline.h"

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

  CancelToken cancel;
  auto report = RunPipeline(cloud, {.stages = {"outliers"}}, cancel);
  ASSERT_TRUE(report.ok()) << report.status();

  size_t true_pos = 0, false_pos = 0, spikes = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    spikes += is_spike[i];
    if (cloud.flags[i] & kRemovedOutlier) (is_spike[i] ? true_pos : false_pos)++;
  }
  EXPECT_GE(true_pos, 0.95 * spikes);
  EXPECT_LE(false_pos, 0.001 * side * side);
  ASSERT_EQ(report->stages.size(), 2u);
  EXPECT_EQ(report->stages[0].name, "neighbourhoods");
  const StageReport& stage = report->stages[1];
  EXPECT_EQ(stage.name, "outliers");
  EXPECT_EQ(stage.points_in, cloud.size());
  EXPECT_EQ(stage.points_out, cloud.size() - true_pos - false_pos);
  EXPECT_NEAR(stage.parameters.at("outliers.mean_d_mm"), 0.2, 0.02);
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
