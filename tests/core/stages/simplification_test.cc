// SPDX-License-Identifier: Apache-2.0
// Simplification (§12, Eq. 13) on the simulator: the spacing reached on a plane, the extra
// density kept at the sharp edges of a box, and no holes (every true sample keeps a point near).
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <string>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/stages/simplification.h"
#include "tests/support/kdtree.h"
#include "tests/support/planned_stages.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

using sim::Part;

PointCloud KeptPoints(const PointCloud& cloud) {
  PointCloud kept;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    kept.x.push_back(cloud.x[i]);
    kept.y.push_back(cloud.y[i]);
    kept.z.push_back(cloud.z[i]);
  }
  kept.FinishLoading();
  return kept;
}

// Mean distance from each selected kept point to its nearest other kept point.
template <typename Select>
double MeanKeptSpacing(const PointCloud& cloud, const KdTree& tree, Select select) {
  double sum = 0;
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i) || !select(i)) continue;
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    uint32_t idx[2];
    float d2[2];
    if (tree.Knn(q, 2, idx, d2) < 2) continue;
    sum += std::sqrt(d2[1]);
    ++count;
  }
  EXPECT_GT(count, 50u);
  return sum / std::max<size_t>(count, 1);
}

// Largest distance from a true surface sample to the nearest kept point.
double LargestHole(const sim::SimulatedCloud& sim, const KdTree& kept_tree) {
  double worst = 0;
  for (const Eigen::Vector3f& t : sim.truth) {
    uint32_t idx;
    float d2;
    kept_tree.Knn(t.data(), 1, &idx, &d2);
    worst = std::max(worst, double(std::sqrt(d2)));
  }
  return worst;
}

// The stage function, called on the inputs its plan's earlier stages built. `before` sees them
// first.
absl::StatusOr<PipelineReport> RunSimplification(
    PointCloud& cloud, const ParamOverrides& params,
    const std::function<void(const PointMeasures&)>& before = {}) {
  return testing::CallStage(cloud, "simplification", params, [&](testing::StageInputs& in) {
    if (before) before(in.measures);
    return Simplify(in.cloud, in.measures, in.neighbourhoods, in.Settings(SimplificationParams()),
                    in.out);
  });
}

void ExpectPlaneSpacing(const std::string& order, const std::string& mode,
                        const std::string& floor = "0") {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 31);
  const double target = 0.5;
  auto report = RunSimplification(sim.cloud, {{"simplification.spacing_mm", "0.5"},
                                              {"simplification.order", order},
                                              {"simplification.mode", mode},
                                              {"simplification.curvature_floor", floor}});
  ASSERT_TRUE(report.ok()) << report.status();
  const PointCloud kept = KeptPoints(sim.cloud);
  const KdTree tree(kept);
  const double spacing = MeanKeptSpacing(sim.cloud, tree, [&](size_t i) {
    return std::abs(sim.truth[i].x()) < 9 && std::abs(sim.truth[i].y()) < 9;
  });
  const double hole = LargestHole(sim, tree);
  std::printf(
      "%s %s plane: %zu of %zu kept, mean spacing %.3f mm (target %.3f), largest hole "
      "%.3f mm\n",
      order.c_str(), mode.c_str(), kept.size(), sim.cloud.size(), spacing, target, hole);
  EXPECT_NEAR(spacing, target, 0.1 * target);
  EXPECT_LE(hole, 2 * target);
  EXPECT_EQ(report->stages.back().parameters.at("simplification.removed"),
            sim.cloud.size() - kept.size());
}

TEST(Simplification, PlaneReachesTheTargetSpacing) { ExpectPlaneSpacing("sequential", "uniform"); }
TEST(Simplification, TiledPlaneReachesTheTargetSpacing) { ExpectPlaneSpacing("tiled", "uniform"); }
TEST(Simplification, AdaptivePlane) { ExpectPlaneSpacing("sequential", "adaptive", "0.2"); }

// Kept points per mm² around the selected kept points: kept neighbours within radius R.
template <typename Select>
double KeptDensity(const PointCloud& cloud, const KdTree& tree, Select select, float radius) {
  RadiusMatches matches;
  double sum = 0;
  size_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i) || !select(i)) continue;
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    sum += tree.Radius(q, radius, matches);
    ++count;
  }
  EXPECT_GT(count, 20u);
  return sum / std::max<size_t>(count, 1) / (M_PI * radius * radius);
}

TEST(Simplification, KeepsEdgesDenseAndLeavesNoHoles) {
  auto sim = sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 32);
  const double target = 0.5;
  auto report = RunSimplification(sim.cloud, {{"simplification.spacing_mm", "0.5"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const PointCloud kept = KeptPoints(sim.cloud);
  const KdTree tree(kept);
  const float band = 0.25f;  // kept points this close to a true sharp edge
  const double edge = KeptDensity(
      sim.cloud, tree, [&](size_t i) { return sim.edge_distance[i] < band; }, 2 * target);
  const double planar = KeptDensity(
      sim.cloud, tree, [&](size_t i) { return sim.edge_distance[i] > 3.0f; }, 2 * target);
  const double hole = LargestHole(sim, tree);
  std::printf(
      "box: %zu of %zu kept; kept density near edges %.2f /mm², planar %.2f /mm² "
      "(ratio %.2f); largest hole %.3f mm\n",
      kept.size(), sim.cloud.size(), edge, planar, edge / planar, hole);
  EXPECT_GE(edge, 2 * planar);
  EXPECT_LE(hole, 2 * target);
}

// §12 step 3 as written: centres one at a time (edge set first, then descending q̂, then index),
// each with a brute-force query over the points still kept. The stage gathers balls for a batch
// of centres in parallel before applying them, which must not change a single removal.
std::vector<bool> RemovedOneCentreAtATime(const PointCloud& cloud, const PointMeasures& m,
                                          float spacing) {
  const size_t n = cloud.size();
  std::vector<bool> removed(n), locked(n);
  for (size_t i = 0; i < n; ++i) removed[i] = cloud.removed(i);
  const auto edge = [&](size_t i) { return m.curvature[i] >= 0.5f; };
  // q̂ clamped to [0, 1], NaN (no normal) as 0.
  const auto q = [&](size_t i) { return m.quality[i] > 0 ? std::min(m.quality[i], 1.f) : 0.f; };
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    if (edge(a) != edge(b)) return edge(a);
    return q(a) != q(b) ? q(a) > q(b) : a < b;
  });
  for (const uint32_t i : order) {
    if (removed[i]) continue;
    std::vector<uint32_t> candidates;
    size_t inside = 0, kept_locked = 0;
    for (uint32_t j = 0; j < n; ++j) {
      if (j == i || removed[j] || !(cloud.squared_distance(i, j) < spacing * spacing)) continue;
      ++inside;
      if (locked[j]) {
        ++kept_locked;
      } else {
        candidates.push_back(j);
      }
    }
    const size_t keep = static_cast<size_t>(std::floor(m.curvature[i] * float(inside) + 0.5f));
    const size_t remove = inside - std::min(inside, std::max(keep, kept_locked));
    std::sort(candidates.begin(), candidates.end(),
              [&](uint32_t a, uint32_t b) { return q(a) != q(b) ? q(a) < q(b) : a < b; });
    for (size_t c = 0; c < remove; ++c) removed[candidates[c]] = true;
    locked[i] = true;
  }
  return removed;
}

// At 0.5 mm a ball holds a few points and a batch 4,096 centres; at 3 mm a ball holds hundreds
// and the batch shrinks to keep the gathered points bounded. Both must match removal for removal.
TEST(Simplification, BatchedVisitsRemoveExactlyWhatOneAtATimeRemoves) {
  for (const float spacing : {0.5f, 3.0f}) {
    auto sim = sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 35);
    PointCloud& cloud = sim.cloud;
    // The paper's order, whose batches this test checks against one centre at a time.
    const ParamOverrides params = {{"simplification.spacing_mm", std::to_string(spacing)},
                                   {"simplification.order", "sequential"}};
    std::vector<bool> expected;
    ASSERT_TRUE(RunSimplification(cloud, params, [&](const PointMeasures& m) {
                  expected = RemovedOneCentreAtATime(cloud, m, spacing);
                }).ok());
    size_t removed = 0, differ = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      removed += cloud.removed(i);
      differ += cloud.removed(i) != expected[i];
    }
    std::printf("box, r_s %.1f mm: %zu of %zu removed, %zu differ from one centre at a time\n",
                spacing, removed, cloud.size(), differ);
    EXPECT_GT(removed, cloud.size() / 2);  // many batches of centres, most of them removed
    EXPECT_EQ(differ, 0u) << "r_s " << spacing;
  }
}

TEST(Simplification, UniformModeIgnoresEdges) {
  auto sim = sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 33);
  auto report = RunSimplification(
      sim.cloud, {{"simplification.spacing_mm", "0.5"}, {"simplification.mode", "uniform"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const PointCloud kept = KeptPoints(sim.cloud);
  const KdTree tree(kept);
  const double edge = KeptDensity(
      sim.cloud, tree, [&](size_t i) { return sim.edge_distance[i] < 0.25f; }, 1.0f);
  const double planar = KeptDensity(
      sim.cloud, tree, [&](size_t i) { return sim.edge_distance[i] > 3.0f; }, 1.0f);
  std::printf("uniform box: kept density near edges %.2f /mm², planar %.2f /mm²\n", edge, planar);
  EXPECT_LT(edge, 1.5 * planar);
}

TEST(Simplification, DerivesTheSpacingFromTheScanPitch) {
  auto sim = sim::Simulate(Part::kPlane, sim::FrontalSensor(Part::kPlane), 34);
  auto report = RunSimplification(sim.cloud, {});
  ASSERT_TRUE(report.ok()) << report.status();
  const ScanMeta& scan = sim.cloud.scans[0];
  EXPECT_NEAR(report->stages.back().parameters.at("simplification.spacing_mm"),
              2 * std::sqrt(scan.scanline_spacing * scan.point_spacing), 0.02);
  EXPECT_EQ(RunSimplification(sim.cloud, {{"simplification.spacing_mm", "0"}}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace scanprep
