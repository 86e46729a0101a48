// SPDX-License-Identifier: Apache-2.0
// The cliffs of unbounded cost, each on a small instance with a control: the work counters
// (candidates a grid query reads, duplicates collapsed, balls capped, radii capped) must stay
// bounded where the input is hostile, so a test fails if a cliff comes back.
#include <algorithm>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <oneapi/tbb/task_arena.h>

#include "core/pipeline/pipeline.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {
namespace {

// A noisy plane of `side`² points at 0.1 mm pitch, one line-scanner scan seen from +z, each row a
// scanline.
PointCloud Plane(int side, uint32_t seed = 5) {
  PointCloud cloud;
  cloud.scans.push_back(ScanMeta{.id = "plane",
                                 .view_direction = Eigen::Vector3d::UnitZ(),
                                 .scanline_spacing = 0.1,
                                 .uncertainty = 0.01});
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 0.005f);
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      cloud.x.push_back(c * 0.1f);
      cloud.y.push_back(r * 0.1f);
      cloud.z.push_back(noise(rng));
      cloud.scanline.push_back(r);
    }
  }
  return cloud;
}

void AddPoint(PointCloud& cloud, float x, float y, float z) {
  cloud.x.push_back(x);
  cloud.y.push_back(y);
  cloud.z.push_back(z);
  cloud.scanline.push_back(cloud.scanline.empty() ? 0 : cloud.scanline.back());
}

// The most candidates any point's k-NN ball (radius d_k) reads from the grid.
size_t MaxCandidates(const PointCloud& cloud) {
  auto nb = Neighbourhoods::Build(cloud, {.k = 20}, CancelToken());
  EXPECT_TRUE(nb.ok()) << nb.status();
  size_t most = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
    if (std::abs(q[0]) > 1e5f) continue;  // the stray point's own ball is the whole cloud
    const uint64_t before = candidates_examined_by_this_thread;
    RadiusMatches ball;
    (*nb)->grid().Within(q, (*nb)->dk(i), ball);
    most = std::max<size_t>(most, candidates_examined_by_this_thread - before);
  }
  return most;
}

TEST(BoundedCost, OneFarPointDoesNotCollapseTheGrid) {
  PointCloud cloud = Plane(150);
  cloud.FinishLoading();
  const size_t control = MaxCandidates(cloud);
  for (float far : {1e6f, 1e8f}) {
    PointCloud stray = Plane(150);
    AddPoint(stray, far, 0.f, 0.f);
    stray.FinishLoading();
    const size_t with_stray = MaxCandidates(stray);
    // Sized from the bounding box, the cells would hold the whole plane: 22,500 candidates.
    EXPECT_LE(with_stray, 2 * control) << "far point at " << far << " mm";
    EXPECT_LE(with_stray, 20u * 20u) << "far point at " << far << " mm";
  }
}

TEST(BoundedCost, CoincidentPointsAreCollapsedAndExpanded) {
  PointCloud cloud = Plane(100);
  // 10 % of the points repeated at one missing-sample position, plus a spike 5 mm above the
  // plane, stated twice: with d₁ = 0 the pair would survive the outlier rule.
  const size_t plane = cloud.size();
  for (size_t d = 0; d < plane / 10; ++d) AddPoint(cloud, 2.5f, 2.5f, 0.f);
  AddPoint(cloud, 5.05f, 5.05f, 5.f);
  AddPoint(cloud, 5.05f, 5.05f, 5.f);
  cloud.FinishLoading();
  PipelineOptions options;
  options.stages = {"outliers", "normals", "smoothing"};
  // The paper's d₁ rule alone: the surface test would catch the spike pair even uncollapsed.
  options.params = {{"outliers.surface_sigmas", "0"}};
  auto report = RunPipeline(cloud, options, CancelToken());
  ASSERT_TRUE(report.ok()) << report.status();
  const StageReport& nb = report->stages.front();
  ASSERT_EQ(nb.name, "neighbourhoods");
  // The plane's points have noisy z, so no plane point is one of the repeats: 999 repeats and one
  // spike copy collapse.
  EXPECT_EQ(nb.parameters.at("neighbourhoods.duplicates_collapsed"), double(plane / 10));
  EXPECT_EQ(nb.points_in, cloud.size());  // the report counts every input point
  // The pile costs nothing: uncollapsed, its 1,000 points would fill (and cap) every ball near it.
  for (const StageReport& stage : report->stages) {
    EXPECT_FALSE(stage.parameters.contains(stage.name + ".balls_capped")) << stage.name;
  }
  // The duplicated spike is judged like a single one.
  EXPECT_TRUE(cloud.flags[cloud.size() - 1] & kRemovedOutlier);
  EXPECT_TRUE(cloud.flags[cloud.size() - 2] & kRemovedOutlier);
  // Every repeat got its representative's result.
  for (size_t d = plane + 1; d < plane + plane / 10; ++d) {
    EXPECT_EQ(cloud.flags[d], cloud.flags[plane]);
    EXPECT_EQ(cloud.z[d], cloud.z[plane]);
    EXPECT_EQ(cloud.nz[d], cloud.nz[plane]);
  }
}

// A blob of 2,000 points within 0.02 mm (far denser than the surface, yet coarser than the
// scan's resolution cubes of u/100, which would make it one measurement: duplicates.h) inside
// the r_min balls of its neighbours: every such ball keeps its nearest 32·k points; the control
// without the blob caps none.
TEST(BoundedCost, BallsInADenseClusterKeepTheirNearest) {
  for (const bool blob : {false, true}) {
    PointCloud cloud = Plane(60);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> jitter(-1e-2f, 1e-2f);
    for (int b = 0; blob && b < 2000; ++b)
      AddPoint(cloud, 3.f + jitter(rng), 3.f + jitter(rng), jitter(rng));
    cloud.FinishLoading();
    PipelineOptions options;
    options.stages = {"normals", "smoothing"};
    auto report = RunPipeline(cloud, options, CancelToken());
    ASSERT_TRUE(report.ok()) << report.status();
    for (const StageReport& stage : report->stages) {
      if (stage.name != "normals" && stage.name != "smoothing") continue;  // the ball stages
      const auto capped = stage.parameters.find(stage.name + ".balls_capped");
      if (!blob) {
        EXPECT_EQ(capped, stage.parameters.end()) << stage.name;
        continue;
      }
      ASSERT_NE(capped, stage.parameters.end()) << stage.name;
      EXPECT_GE(capped->second, 2000) << stage.name;  // at least the blob's own balls
      EXPECT_GT(stage.parameters.at(stage.name + ".ball_points_left_out"), 0) << stage.name;
    }
    EXPECT_EQ(report->warnings.empty(), !blob);
  }
}

// Candidates the default pipeline's index queries read per point of `cloud`, counted on one
// thread (a one-thread arena runs every parallel loop on the caller, whose counter sums them).
double CandidatesPerPoint(PointCloud cloud, ParamOverrides params = {}) {
  cloud.FinishLoading();
  const uint64_t before = candidates_examined_by_this_thread;
  absl::StatusOr<PipelineReport> report;
  tbb::task_arena(1).execute(
      [&] { report = RunPipeline(cloud, {.params = std::move(params)}, CancelToken()); });
  EXPECT_TRUE(report.ok()) << report.status();
  return double(candidates_examined_by_this_thread - before) / double(cloud.size());
}

// A glint: a fifth, then half, of the points of a 0.1 mm-pitch plane piled within u/2 of one
// spot, far denser than the surface yet coarser than the duplicate collapse (u/100). Every ball
// around it is 8·d_k or wider, so the k-NN list stands for it (kStandInRadiusPerDk), and the
// grid's cells stay sized for the surface (a median d_k would be the spot's at half the points):
// the work a point does stays of the order of its k-NN list, per point within 1.5× of the
// control, the same plane with those points spread over more of it. Without the stand-in the
// fifth reads 8× the control; with cells sized by the median d_k, the half 3×. Again at r_s =
// 1 mm, where simplification's cap is 8x a ball of r_s (2,500, not 640) and the stand-in's
// radius grows with it: with the stand-in for the default cap only, every centre near the spot
// read its removed points again (3.3× and 6.8×).
TEST(BoundedCost, WorkPerPointIsFlatOnADenseSpot) {
  constexpr int kSide = 120;
  for (const int piled : {kSide * kSide / 4, kSide * kSide}) {
    PointCloud dense = Plane(kSide);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(-1.f, 1.f);
    for (int b = 0; b < piled;) {
      const float d[3] = {unit(rng), unit(rng), unit(rng)};
      if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1.f) continue;
      const float half_u = 0.005f;
      AddPoint(dense, 6.f + half_u * d[0], 6.f + half_u * d[1], half_u * d[2]);
      ++b;
    }
    PointCloud control = Plane(kSide + 1);  // as many points, all on the surface
    for (int r = 0; control.size() < dense.size(); ++r) {
      for (int c = 0; c < kSide && control.size() < dense.size(); ++c) {
        AddPoint(control, c * 0.1f, (kSide + 1 + r) * 0.1f, 0.f);
        control.scanline.back() = kSide + 1 + r;
      }
    }
    const double ordinary = CandidatesPerPoint(control);
    const double glint = CandidatesPerPoint(dense);
    std::printf("%d piled: candidates per point: ordinary %.0f, dense spot %.0f (%.2fx)\n", piled,
                ordinary, glint, glint / ordinary);
    EXPECT_LE(glint, 1.5 * ordinary) << piled << " piled";
    const ParamOverrides wide = {{"simplification.spacing_mm", "1"}};
    const double wide_ordinary = CandidatesPerPoint(std::move(control), wide);
    const double wide_glint = CandidatesPerPoint(std::move(dense), wide);
    std::printf("%d piled, r_s 1 mm: ordinary %.0f, dense spot %.0f (%.2fx)\n", piled,
                wide_ordinary, wide_glint, wide_glint / wide_ordinary);
    EXPECT_LE(wide_glint, 1.5 * wide_ordinary) << piled << " piled, r_s 1 mm";
  }
}

// Candidates per point of the default pipeline on Plane(60) sampled `factor`² times as densely
// (pitch and stated scanline spacing shrunk alike), the scan's uncertainty u set to `u`.
double CandidatesPerPointAtDensity(int factor, double u) {
  PointCloud cloud = Plane(60 * factor);
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud.x[i] /= float(factor);
    cloud.y[i] /= float(factor);
  }
  cloud.scans[0].scanline_spacing = 0.1f / float(factor);
  cloud.scans[0].uncertainty = u;
  const double per_point = CandidatesPerPoint(std::move(cloud));
  std::printf("%dx density, u %g mm: %.0f candidates per point\n", factor * factor, u, per_point);
  return per_point;
}

// The same part sampled 4× and 16× as densely: the work per point stays flat, within 1.5× of
// the sparsest.
TEST(BoundedCost, WorkPerPointIsFlatAsDensityGrows) {
  const double sparsest = CandidatesPerPointAtDensity(1, 0.01);
  for (const int factor : {2, 4}) {
    EXPECT_LE(CandidatesPerPointAtDensity(factor, 0.01), 1.5 * sparsest)
        << factor * factor << "x the density";
  }
}

// The same, with the scanner's stated uncertainty u fixed in mm (0.2 mm, a datasheet's
// conservative figure) as the sampling grows denser, as on a real sensor: Eq. (2)'s
// r_min = √3·Δs + u then holds ever more points, up to its limit of 3·r_g at 16×, and every fit
// read its whole ball: 1.5× and 2.0× the sparsest's candidates per point at 4× and 16×. Where a
// ball holds more than a fit needs, an even lattice of it stands for it (Neighbourhoods::Sample):
// 0.97× and 1.13×.
TEST(BoundedCost, WorkPerPointIsFlatAsDensityGrowsUnderAFixedUncertainty) {
  const double sparsest = CandidatesPerPointAtDensity(1, 0.2);
  for (const int factor : {2, 4}) {
    EXPECT_LE(CandidatesPerPointAtDensity(factor, 0.2), 1.25 * sparsest)
        << factor * factor << "x the density";
  }
}

TEST(BoundedCost, MergeRadiusOverrideIsCapped) {
  PointCloud cloud = Plane(80);
  const size_t first_scan = cloud.size();
  PointCloud second = Plane(80, 9);
  cloud.scans.push_back(second.scans[0]);
  cloud.scans[1].id = "again";
  for (size_t i = 0; i < second.size(); ++i) {
    AddPoint(cloud, second.x[i] + 0.05f, second.y[i] + 0.05f, second.z[i]);
  }
  cloud.FinishLoading();
  for (size_t i = first_scan; i < cloud.size(); ++i) cloud.scan[i] = 1;
  PipelineOptions options;
  options.stages = {"correction"};
  options.params["correction.radius_mm"] = "10000";  // the largest the declaration admits
  auto report = RunPipeline(cloud, options, CancelToken());
  ASSERT_TRUE(report.ok()) << report.status();
  const StageReport& correction = report->stages.back();
  ASSERT_EQ(correction.name, "correction");
  const double r_g = report->stages.front().parameters.at("neighbourhoods.global_radius_mm");
  EXPECT_EQ(correction.parameters.at("correction.radii_capped"), 2);
  EXPECT_LE(correction.parameters.at("correction.radius_mm.scan0"), 2 * r_g + 1e-6);
  // Control: the default r_c is left alone.
  PointCloud control = cloud;
  control.FinishLoading();
  options.params.clear();
  auto plain = RunPipeline(control, options, CancelToken());
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_FALSE(plain->stages.back().parameters.contains("correction.radii_capped"));
  EXPECT_FALSE(plain->stages.back().parameters.contains("correction.balls_capped"));
}

}  // namespace
}  // namespace scanprep
