// SPDX-License-Identifier: Apache-2.0
// Merging overlapping scans (§10) on the simulator: the frontal and an oblique, noisier scan of a
// sphere. Ground truth says, for every removed point, which scan views its true surface point
// worse, and where the other scan does not reach at all.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/correction.h"
#include "tests/support/kdtree.h"
#include "tests/support/planned_stages.h"
#include "tests/support/stage_call.h"

namespace scanprep {
namespace {

using sim::Part;

// The worse of the viewing and projection angles of scan `meta` at true point t with normal n.
double TrueAngle(const ScanMeta& meta, const Eigen::Vector3f& t, const Eigen::Vector3f& n) {
  const Eigen::Vector3d to_camera = (*meta.camera_position - t.cast<double>()).normalized();
  const double alpha = std::acos(std::min(1.0, std::abs(n.cast<double>().dot(to_camera))));
  const double beta =
      std::acos(std::min(1.0, std::abs(n.cast<double>().dot(*meta.projector_direction))));
  return std::max(alpha, beta);
}

// The points of one scan as their own cloud, to ask "how far is the other scan from here?".
PointCloud ScanPoints(const PointCloud& cloud, uint32_t scan) {
  PointCloud part;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.scan[i] != scan) continue;
    part.x.push_back(cloud.x[i]);
    part.y.push_back(cloud.y[i]);
    part.z.push_back(cloud.z[i]);
  }
  part.FinishLoading();
  return part;
}

struct Outcome {
  size_t removed = 0, from_worse = 0, single_covered = 0, removed_single = 0;
  std::array<size_t, 2> removed_per_scan{};
};

Outcome Evaluate(const sim::SimulatedCloud& sim, const PointCloud& original) {
  const PointCloud& cloud = sim.cloud;
  const std::array<PointCloud, 2> scans = {ScanPoints(original, 0), ScanPoints(original, 1)};
  const KdTree tree0(scans[0]), tree1(scans[1]);
  const std::array<const KdTree*, 2> trees = {&tree0, &tree1};
  Outcome o;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const uint32_t own = cloud.scan[i], other = 1 - own;
    // "Only one scan covers the surface here": the other scan's nearest point is 2 mm away.
    const float q[3] = {original.x[i], original.y[i], original.z[i]};
    uint32_t idx;
    float d2;
    trees[other]->Knn(q, 1, &idx, &d2);
    const bool single = d2 > 4.0f;
    o.single_covered += single;
    if (!(cloud.flags[i] & kRemovedMerge)) continue;
    ++o.removed;
    ++o.removed_per_scan[own];
    o.removed_single += single;
    const double own_angle = TrueAngle(cloud.scans[own], sim.truth[i], sim.true_normal[i]);
    const double other_angle = TrueAngle(cloud.scans[other], sim.truth[i], sim.true_normal[i]);
    // The oblique scan also has twice the noise: at equal angles it is the worse one.
    o.from_worse += own_angle > other_angle || (own == 1 && own_angle == other_angle);
  }
  return o;
}

// The stage function, called on the quality its plan's earlier stages measured; `before` sees
// its inputs first, and `capped_after` receives the neighbourhoods' capped-ball count after it.
absl::StatusOr<PipelineReport> RunCorrection(
    PointCloud& cloud, const ParamOverrides& params = {},
    const std::function<void(const testing::StageInputs&)>& before = {},
    uint64_t* capped_after = nullptr) {
  return testing::CallStage(cloud, "correction", params, [&](testing::StageInputs& in) {
    if (before) before(in);
    absl::Status done = CorrectOverlaps(in.cloud, in.measures, in.neighbourhoods,
                                        in.Settings(CorrectionParams()), in.out)
                            .status();
    if (capped_after) *capped_after = in.neighbourhoods.capped_balls();
    return done;
  });
}

void ExpectMergesOverlap(const std::string& mode) {
  auto sim = sim::Simulate(Part::kSphere, sim::TwoOverlappingSensors(Part::kSphere), 21);
  const PointCloud original = sim.cloud;
  auto report = RunCorrection(sim.cloud, {{"correction.mode", mode}});
  ASSERT_TRUE(report.ok()) << report.status();
  const Outcome o = Evaluate(sim, original);
  std::printf(
      "%s: %zu of %zu removed (scan0 %zu, scan1 %zu), %.1f %% from the worse view; "
      "%zu single-covered points, %zu of them removed\n",
      mode.c_str(), o.removed, original.size(), o.removed_per_scan[0], o.removed_per_scan[1],
      100.0 * o.from_worse / std::max<size_t>(o.removed, 1), o.single_covered, o.removed_single);
  EXPECT_GT(o.removed, original.size() / 10);
  EXPECT_GE(o.from_worse, 0.8 * o.removed);
  EXPECT_GT(o.single_covered, 300u);
  EXPECT_EQ(o.removed_single, 0u);
  const StageReport& stage = report->stages.back();
  EXPECT_EQ(stage.name, "correction");
  EXPECT_EQ(stage.parameters.at("correction.removed"), o.removed);
  const ScanMeta& s0 = original.scans[0];
  EXPECT_NEAR(stage.parameters.at("correction.radius_mm.scan0"),
              std::sqrt(s0.scanline_spacing * s0.scanline_spacing +
                        s0.uncertainty * s0.uncertainty + s0.point_spacing * s0.point_spacing),
              0.01);
}

TEST(Correction, GatherRemovesTheWorseLayerOnly) { ExpectMergesOverlap("gather"); }
TEST(Correction, ScatterRemovesTheWorseLayerOnly) { ExpectMergesOverlap("scatter"); }

// The gather form decides from labels of the previous round only: visiting order, and so the
// order of the points in the arrays, cannot change which points go.
TEST(Correction, GatherIgnoresPointOrder) {
  auto sim = sim::Simulate(Part::kSphere, sim::TwoOverlappingSensors(Part::kSphere), 24);
  PointCloud reversed = sim.cloud;
  const size_t n = reversed.size();
  auto flip = [&](auto& v) { std::reverse(v.begin(), v.end()); };
  flip(reversed.x), flip(reversed.y), flip(reversed.z), flip(reversed.scan),
      flip(reversed.scanline);
  ASSERT_TRUE(RunCorrection(sim.cloud).ok());
  ASSERT_TRUE(RunCorrection(reversed).ok());
  size_t differ = 0, removed = 0;
  for (size_t i = 0; i < n; ++i) {
    removed += sim.cloud.removed(i);
    differ += sim.cloud.removed(i) != reversed.removed(n - 1 - i);
  }
  std::printf("reversed order: %zu of %zu removals differ\n", differ, removed);
  EXPECT_GT(removed, n / 10);
  EXPECT_LE(differ, removed / 1000);
}

// One scan has nothing to merge: every point stays, and the stage says it changed nothing (a
// client that sent two scans as one would otherwise never learn why nothing merged).
TEST(Correction, SingleScanIsUntouchedAndSaysSo) {
  auto sim = sim::Simulate(Part::kSphere, sim::FrontalSensor(Part::kSphere), 22);
  auto report = RunCorrection(sim.cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(sim.cloud.CountKept(), sim.cloud.size());
  EXPECT_EQ(report->stages.back().parameters.at("correction.single_scan"), 1);
  EXPECT_EQ(report->stages.back().parameters.at("correction.removed"), 0);
  ASSERT_EQ(report->warnings.size(), 1u);
  EXPECT_EQ(report->warnings[0].code, WarningCode::kSingleScanNoMerge);
  EXPECT_NE(report->warnings[0].message.find("one scan"), std::string::npos)
      << report->warnings[0].message;
}

// Two overlapping scans without poses or quality: every q̂ is 1, so no overlap can be resolved.
// The stage must say so (warning and report flag), not return as if it had merged; the same
// scans with their poses are the control.
TEST(Correction, WithoutQualityTheMergeSaysItDidNothing) {
  auto sim = sim::Simulate(Part::kSphere, sim::TwoOverlappingSensors(Part::kSphere), 25);
  PointCloud posed = sim.cloud;
  for (ScanMeta& scan : sim.cloud.scans) {
    scan.camera_position.reset();
    scan.projector_direction.reset();
    scan.view_direction.reset();
    scan.projector_position.reset();
  }
  auto report = RunCorrection(sim.cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->stages.back().parameters.at("correction.without_quality"), 1);
  EXPECT_EQ(sim.cloud.CountKept(), sim.cloud.size());
  bool warned = false;
  for (const Warning& w : report->warnings) {
    warned = warned || w.code == WarningCode::kUniformQualityNoMerge;
  }
  EXPECT_TRUE(warned);

  auto control = RunCorrection(posed);
  ASSERT_TRUE(control.ok()) << control.status();
  EXPECT_EQ(control->stages.back().parameters.at("correction.without_quality"), 0);
  EXPECT_LT(posed.CountKept(), posed.size());
}

// The gather rule as docs/algorithms.md §10 states it, from scratch on kd-tree balls: every round
// judges every unremoved point whose ball spanned two scans last time, on the labels of the
// round before; a ball fuller than `cap` keeps its nearest (ties to the lower index), and a ball
// kStandInRadiusPerDk·d_k or wider is the point and its k nearest others (the k-NN list stands in).
// A ball that `sampled` (the index's Sample, its lattice tested in cell_grid_test) reads as a
// lattice is that lattice: what is checked here is which centres are judged again, not the ball.
std::vector<uint8_t> ReferenceGather(const PointCloud& cloud, const std::vector<uint8_t>& flags,
                                     const std::vector<float>& quality,
                                     const std::vector<float>& radius, size_t cap,
                                     const Neighbourhoods& sampled) {
  const KdTree tree(cloud);
  std::vector<uint8_t> gone(cloud.size(), 0), settled(cloud.size(), 0);
  for (size_t i = 0; i < cloud.size(); ++i) gone[i] = (flags[i] & kRemovedMask) != 0;
  RadiusMatches ball;
  constexpr uint32_t kK = kDefaultNeighbourK;
  std::vector<uint32_t> idx(kK + 1);
  std::vector<float> d2(kK + 1);
  for (int round = 0; round < 10; ++round) {
    std::vector<uint8_t> next = gone;
    for (size_t i = 0; i < cloud.size(); ++i) {
      if (gone[i] || settled[i]) continue;
      const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      const float r = radius[cloud.scan[i]];
      tree.Knn(q, kK + 1, idx.data(), d2.data());  // i itself first, then its k nearest others
      const uint64_t lattices = sampled.sampled_balls();
      sampled.Sample(cloud, i, r, ball, 0);
      if (sampled.sampled_balls() > lattices) {
        // the lattice
      } else if (r >= kStandInRadiusPerDk * std::sqrt(d2[kK])) {
        ball.clear();
        for (uint32_t m = 0; m <= kK; ++m) ball.emplace_back(idx[m], d2[m]);
      } else {
        tree.Radius(q, r, ball);
      }
      std::erase_if(ball, [&](const auto& m) { return gone[m.first] != 0; });
      std::sort(ball.begin(), ball.end(), [](const auto& a, const auto& b) {
        return a.second < b.second || (a.second == b.second && a.first < b.first);
      });
      if (ball.size() > cap) ball.resize(cap);
      double sum = 0;
      uint32_t best = ball.front().first;
      bool spans = false;
      for (const auto& [j, d2] : ball) {
        sum += quality[j];
        if (quality[j] > quality[best] || (quality[j] == quality[best] && j < best)) best = j;
        spans |= cloud.scan[j] != cloud.scan[i];
      }
      settled[i] = !spans;
      const float mean = static_cast<float>(sum / static_cast<double>(ball.size()));
      next[i] = spans && cloud.scan[i] != cloud.scan[best] && quality[i] < mean;
    }
    if (next == gone) break;
    gone.swap(next);
  }
  return gone;
}

// After its first round the stage judges again only the points within r_c of a point the round
// before removed (elsewhere no ball changed); that must remove exactly what judging every point
// every round removes. On scans with different r_c (the oblique scan is noisier) and with a dense
// cluster of both scans in the overlap, whose balls are capped.
TEST(Correction, GatherJudgesAgainOnlyWhereABallLostAPoint) {
  // No cluster; 2 × 1500 points within 0.05 mm (about r_c / 4) of a point both scans see, whose
  // balls are 8·d_k or wider and stood in for by the k-NN lists; the same spread over 0.13 mm
  // and over 0.07 and 0.13 mm (about r_c / 2), whose verdicts read a lattice of their balls
  // (Neighbourhoods::Sample) and whose search for touched centres is capped: at 0.07 mm a centre
  // beyond a removed point's capped search changes its verdict (taken as complete, one differs;
  // the one point a capped search misses is rarely in a centre's lattice: 0.06 and 0.08-0.5 mm,
  // up to 6,000 points, showed none).
  for (const float spread : {0.f, 0.05f, 0.07f, 0.13f}) {
    const bool cluster = spread > 0;
    auto sim = sim::Simulate(Part::kSphere, sim::TwoOverlappingSensors(Part::kSphere), 25);
    PointCloud& cloud = sim.cloud;
    if (cluster) {
      const size_t at = cloud.size() / 2;
      std::mt19937 rng(3);
      std::uniform_real_distribution<float> jitter(-spread, spread);
      for (uint32_t m = 0; m < 3000; ++m) {
        cloud.x.push_back(cloud.x[at] + jitter(rng));
        cloud.y.push_back(cloud.y[at] + jitter(rng));
        cloud.z.push_back(cloud.z[at] + jitter(rng));
        cloud.scan.push_back(m % 2);
        cloud.scanline.push_back(cloud.scanline[at]);
      }
      cloud.FinishLoading();
    }
    std::vector<float> quality;
    std::vector<uint8_t> flags;
    size_t cap = 0;
    uint64_t capped_before = 0, capped_after = 0;
    auto report = RunCorrection(
        cloud, {},
        [&](const testing::StageInputs& in) {
          quality = in.measures.quality;
          flags = in.cloud.flags;
          cap = in.neighbourhoods.max_ball_points();
          capped_before = in.neighbourhoods.capped_balls();
        },
        &capped_after);
    ASSERT_TRUE(report.ok()) << report.status();
    const StageReport& stage = report->stages.back();
    ASSERT_EQ(stage.name, "correction");
    const std::vector<float> radius = {
        static_cast<float>(stage.parameters.at("correction.radius_mm.scan0")),
        static_cast<float>(stage.parameters.at("correction.radius_mm.scan1"))};
    EXPECT_GT(std::abs(radius[1] - radius[0]), 0.02f * radius[0]);
    EXPECT_GT(stage.parameters.at("correction.rounds_run"), 2);
    EXPECT_EQ(capped_after > capped_before, cluster);

    auto sampled = Neighbourhoods::Build(cloud, {.k = kDefaultNeighbourK}, CancelToken());
    ASSERT_TRUE(sampled.ok()) << sampled.status();
    const std::vector<uint8_t> expected =
        ReferenceGather(cloud, flags, quality, radius, cap, **sampled);
    size_t removed = 0, differ = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      removed += (cloud.flags[i] & kRemovedMerge) != 0;
      differ +=
          ((cloud.flags[i] & kRemovedMerge) != 0) != (expected[i] && !(flags[i] & kRemovedMask));
    }
    std::printf(
        "cluster spread %g mm: %zu removed, %zu differ from judging every point every round\n",
        spread, removed, differ);
    EXPECT_GT(removed, cloud.size() / 10);
    EXPECT_EQ(differ, 0u);
  }
}

TEST(Correction, RadiusScaleWidensTheMergeRadius) {
  auto sim = sim::Simulate(Part::kPlane, sim::TwoOverlappingSensors(Part::kPlane), 23);
  auto report = RunCorrection(sim.cloud, {{"correction.radius_scale", "2"}});
  ASSERT_TRUE(report.ok()) << report.status();
  const ScanMeta& s1 = sim.cloud.scans[1];
  EXPECT_NEAR(report->stages.back().parameters.at("correction.radius_mm.scan1"),
              2 * std::sqrt(s1.scanline_spacing * s1.scanline_spacing +
                            s1.uncertainty * s1.uncertainty + s1.point_spacing * s1.point_spacing),
              0.02);
  EXPECT_EQ(RunCorrection(sim.cloud, {{"correction.radius_scale", "-1"}}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace scanprep
