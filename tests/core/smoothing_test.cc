// Smoothing against the simulator's true surfaces: noise drops on flat parts, sharp box edges
// keep their shape because the tolerance test (Eq. 10) rejects the long moves there.
#include <cmath>

#include <gtest/gtest.h>

#include "core/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

using sim::Part;

// RMS distance to the true surface over the points `select` accepts.
template <typename Select>
double RmsToSurface(Part part, const PointCloud& cloud, Select select) {
  double sum = 0;
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!select(i)) continue;
    const double d = sim::DistanceToSurface(part, cloud.point(i).cast<double>());
    sum += d * d;
    ++count;
  }
  EXPECT_GT(count, 100u);
  return std::sqrt(sum / std::max<size_t>(count, 1));
}

absl::StatusOr<PipelineReport> Smooth(PointCloud& cloud, ParamOverrides params = {}) {
  CancelToken cancel;
  return RunPipeline(cloud, {.stages = {"smoothing"}, .params = std::move(params)}, cancel);
}

TEST(Smoothing, LowersNoiseOnAPlane) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 11);
  PointCloud& cloud = sim.cloud;
  // Away from the border, where a neighbourhood is one-sided.
  auto interior = [&](size_t i) {
    return std::abs(sim.truth[i].x()) < 9 && std::abs(sim.truth[i].y()) < 9;
  };
  const double before = RmsToSurface(Part::kPlane, cloud, interior);
  auto report = Smooth(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const double after = RmsToSurface(Part::kPlane, cloud, interior);
  std::printf("plane RMS to true surface: before %.4f mm, after %.4f mm (%.0f %% lower)\n", before,
              after, 100 * (1 - after / before));
  EXPECT_LE(after, 0.6 * before);
  const auto& params = report->stages.back().parameters;
  EXPECT_EQ(report->stages.back().name, "smoothing");
  EXPECT_GT(params.at("smoothing.moved"), 0.9 * cloud.size());
  EXPECT_NEAR(params.at("smoothing.tolerance_mm"), cloud.scans[0].uncertainty, 1e-6);
  EXPECT_DOUBLE_EQ(params.at("smoothing.lambda"), 0.5);
}

TEST(Smoothing, KeepsSharpEdgesOfABox) {
  auto sim = sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 12);
  PointCloud& cloud = sim.cloud;
  const PointCloud original = cloud;
  const float spacing = static_cast<float>(cloud.scans[0].scanline_spacing);
  auto near_edge = [&](size_t i) { return sim.edge_distance[i] <= spacing; };
  auto flat = [&](size_t i) { return sim.edge_distance[i] > 2.0f; };
  const double edge_before = RmsToSurface(Part::kBoxWithBore, cloud, near_edge);
  const double flat_before = RmsToSurface(Part::kBoxWithBore, cloud, flat);
  auto report = Smooth(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const double edge_after = RmsToSurface(Part::kBoxWithBore, cloud, near_edge);
  const double flat_after = RmsToSurface(Part::kBoxWithBore, cloud, flat);
  const double delta = cloud.scans[0].uncertainty;
  float longest_edge_move = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (near_edge(i)) {
      longest_edge_move = std::max(longest_edge_move, (cloud.point(i) - original.point(i)).norm());
    }
  }
  std::printf("box: edge RMS %.4f -> %.4f mm, flat RMS %.4f -> %.4f mm, longest edge move %.4f mm"
              " (δ %.3f)\n", edge_before, edge_after, flat_before, flat_after, longest_edge_move,
              delta);
  EXPECT_LE(longest_edge_move, delta * (1 + 1e-4));
  EXPECT_LE(edge_after, 1.1 * edge_before);
  // The box's side faces are seen obliquely: noisier than δ allows more often than on the plane.
  EXPECT_LE(flat_after, 0.75 * flat_before);
  EXPECT_GT(report->stages.back().parameters.at("smoothing.rejected"), 0);

  // Control: without the tolerance test (δ far above any move) the same weights round the edge.
  PointCloud unguarded = original;
  ASSERT_TRUE(Smooth(unguarded, {{"smoothing.tolerance_mm", "10"}}).ok());
  const double edge_unguarded = RmsToSurface(Part::kBoxWithBore, unguarded, near_edge);
  std::printf("box without tolerance test: edge RMS %.4f mm\n", edge_unguarded);
  EXPECT_GT(edge_unguarded, 1.1 * edge_before);
}

TEST(Smoothing, ClampModeNeverMovesFartherThanTheTolerance) {
  auto sim = sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 13);
  PointCloud& cloud = sim.cloud;
  const PointCloud original = cloud;
  auto report = Smooth(cloud, {{"smoothing.tolerance", "clamp"},
                               {"smoothing.tolerance_mm", "0.01"},
                               {"smoothing.iterations", "2"}});
  ASSERT_TRUE(report.ok()) << report.status();
  float longest = 0;
  size_t flagged = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    longest = std::max(longest, (cloud.point(i) - original.point(i)).norm());
    flagged += (cloud.flags[i] & kSmoothed) != 0;
  }
  EXPECT_LE(longest, 2 * 0.01f * (1 + 1e-4));  // two passes of at most δ each
  EXPECT_GT(longest, 0.01f);
  EXPECT_EQ(report->stages.back().parameters.at("smoothing.rejected"), 0);
  EXPECT_GT(flagged, cloud.size() / 2);
}

TEST(Smoothing, RejectsALambdaOutsideTheUnitInterval) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 14);
  auto report = Smooth(sim.cloud, {{"smoothing.lambda", "1.5"}});
  EXPECT_EQ(report.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(report.status().message().find("smoothing.lambda"), std::string::npos);
}

}  // namespace
}  // namespace scanprep
