// SPDX-License-Identifier: Apache-2.0
// Degenerate clouds through every stage: each job ends with a result or a precise error, never a
// crash, a hang or a NaN; where the geometry leaves no doubt (a plane stays a plane, identical
// points stay put) the result is checked against it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

const std::vector<std::string> kAllStages = {"outliers",     "normals",       "measures",
                                             "registration", "correction",    "health",
                                             "smoothing",    "simplification"};

// A line-scanner scan seen from +z with the given scanline spacing.
ScanMeta TopViewScan(const std::string& id, double scanline_spacing) {
  return ScanMeta{
      .id = id, .view_direction = Eigen::Vector3d::UnitZ(), .scanline_spacing = scanline_spacing};
}

void AddPoint(PointCloud& cloud, float x, float y, float z, uint32_t scan = 0) {
  cloud.x.push_back(x);
  cloud.y.push_back(y);
  cloud.z.push_back(z);
  cloud.scan.push_back(scan);
}

// rows × cols grid with `step` spacing in the plane z = z0, offset by (x0, y0); row r is
// scanline r.
PointCloud Grid(int rows, int cols, float step, float x0 = 0, float y0 = 0, float z0 = 0) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("grid", step));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      AddPoint(cloud, x0 + c * step, y0 + r * step, z0);
      cloud.scanline.push_back(static_cast<uint32_t>(r));
    }
  }
  return cloud;
}

absl::StatusOr<PipelineReport> RunAllStages(PointCloud& cloud) {
  cloud.FinishLoading();
  CancelToken cancel;
  auto report = RunPipeline(cloud, PipelineOptions{.stages = kAllStages}, cancel);
  if (report.ok()) {
    for (const StageReport& stage : report->stages) {
      std::printf("  %-15s %6llu -> %6llu points %7.3f s\n", stage.name.c_str(),
                  static_cast<unsigned long long>(stage.points_in),
                  static_cast<unsigned long long>(stage.points_out), stage.seconds);
    }
  }
  return report;
}

// A job that cannot run says which parameter or input is at fault: INVALID_ARGUMENT naming a
// "<stage>.<param>".
void ExpectResultOrPreciseError(const absl::StatusOr<PipelineReport>& report) {
  if (report.ok()) return;
  EXPECT_EQ(report.status().code(), absl::StatusCode::kInvalidArgument) << report.status();
  const std::string message(report.status().message());
  const bool names_a_parameter =
      std::any_of(kAllStages.begin(), kAllStages.end(),
                  [&](const std::string& stage) { return message.rfind(stage + ".", 0) == 0; });
  EXPECT_TRUE(names_a_parameter) << message;
}

// Coordinates of every point, and normals of every kept point not flagged invalid, are finite.
// (Removed points get no normal estimate.)
void ExpectFinite(const PointCloud& cloud) {
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_TRUE(cloud.point(i).allFinite()) << "point " << i;
    if (cloud.has_normals() && !cloud.removed(i) && (cloud.flags[i] & kNormalInvalid) == 0) {
      ASSERT_TRUE(cloud.normal(i).allFinite()) << "normal " << i;
      ASSERT_NEAR(cloud.normal(i).norm(), 1.0f, 1e-4f) << "normal " << i;
    }
  }
}

// Every kept point lies on the plane z = z0 (within `tol`) and every valid normal is ±z.
void ExpectStillPlane(const PointCloud& cloud, float z0, float tol) {
  size_t valid_normals = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    EXPECT_NEAR(cloud.z[i], z0, tol) << "point " << i;
    if ((cloud.flags[i] & kNormalInvalid) != 0) continue;
    ++valid_normals;
    EXPECT_GT(std::abs(cloud.nz[i]), 0.999f)
        << "normal " << i << ": " << cloud.normal(i).transpose();
  }
  EXPECT_GT(valid_normals, 0u);
}

// Zero and one point run every stage to a result (nothing to thin); one point has no plane.
TEST(DegenerateClouds, ZeroPoints) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("empty", 0.5));
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_EQ(report->stages.back().parameters.at("simplification.removed"), 0);
}

TEST(DegenerateClouds, OnePointIsKeptWithAnInvalidNormal) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("one", 0.5));
  AddPoint(cloud, 1, 2, 3);
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_FALSE(cloud.removed(0));
  EXPECT_EQ(cloud.point(0), Eigen::Vector3f(1, 2, 3));
  EXPECT_NE(cloud.flags[0] & kNormalInvalid, 0);
}

TEST(DegenerateClouds, TwoPointsKeepTheirPositions) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("two", 0.5));
  AddPoint(cloud, 0, 0, 0);
  AddPoint(cloud, 1, 0, 0);
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  EXPECT_GE(cloud.CountKept(), 1u);
  for (size_t i = 0; i < 2; ++i) {
    if (cloud.removed(i)) continue;
    EXPECT_EQ(cloud.point(i), Eigen::Vector3f(static_cast<float>(i), 0, 0));
    EXPECT_NE(cloud.flags[i] & kNormalInvalid, 0) << "two points define no plane";
  }
}

// The minimum radius from the stated scanline spacing is capped at 5 r_g; with r_g = 0 the balls
// hold the point alone instead of every coincident copy (which used to cost O(copies²)).
// Simplification finds no spacing to derive here and refuses with INVALID_ARGUMENT
// (simplification.spacing_mm) after the earlier stages ran, so their effect is checked either way.
TEST(DegenerateClouds, TenThousandIdenticalPointsStayPut) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("same", 0.5));
  for (int i = 0; i < 10'000; ++i) AddPoint(cloud, 5, -3, 7);
  ExpectResultOrPreciseError(RunAllStages(cloud));
  ExpectFinite(cloud);
  EXPECT_GE(cloud.CountKept(), 1u);
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_EQ(cloud.point(i), Eigen::Vector3f(5, -3, 7)) << i;
  }
}

TEST(DegenerateClouds, CollinearPointsStayOnTheirLine) {
  PointCloud cloud;
  cloud.scans.push_back(TopViewScan("line", 0.5));
  // Along (1, 2, 2)/3, 0.3 mm apart: not axis-aligned, so no coordinate is trivially constant.
  for (int i = 0; i < 500; ++i) {
    const float t = 0.3f * static_cast<float>(i);
    AddPoint(cloud, t / 3, 2 * t / 3, 2 * t / 3);
  }
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  EXPECT_GE(cloud.CountKept(), 2u);
  const Eigen::Vector3f direction = Eigen::Vector3f(1, 2, 2) / 3;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f p = cloud.point(i);
    EXPECT_LT((p - p.dot(direction) * direction).norm(), 1e-3f) << "point " << i;
    // A line has no normal: either flagged invalid or at least perpendicular to the line.
    if (cloud.has_normals() && (cloud.flags[i] & kNormalInvalid) == 0) {
      EXPECT_LT(std::abs(cloud.normal(i).dot(direction)), 1e-3f) << "normal " << i;
    }
  }
}

TEST(DegenerateClouds, CoplanarGridStaysAPlane) {
  PointCloud cloud = Grid(40, 40, 0.5f);
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  ExpectStillPlane(cloud, 0, 1e-4f);
}

// A scanline spacing stated 200× too large (e.g. mm in a job declared in metres' place) would make
// every ball the whole grid, and the derived thinning spacing r_s (14 mm) thin it to a few points;
// the caps
// keep both at the data's own scale, count them and say why in a warning.
TEST(DegenerateClouds, ScanlineSpacingFarTooLargeIsCappedAndReported) {
  PointCloud cloud = Grid(120, 120, 0.5f);
  cloud.scans[0].scanline_spacing = 100;
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  const StageReport& nb = report->stages.front();
  ASSERT_EQ(nb.name, "neighbourhoods");
  EXPECT_NEAR(nb.parameters.at("neighbourhoods.min_radius_mm"), std::sqrt(3.0) * 100 + 0.1, 1e-6);
  EXPECT_LE(nb.parameters.at("neighbourhoods.min_radius_used_mm"),
            5 * nb.parameters.at("neighbourhoods.global_radius_mm") + 1e-9);
  EXPECT_EQ(nb.parameters.at("neighbourhoods.radii_capped"), 1);
  auto warned = [&](std::string_view a, std::string_view b) {
    return std::any_of(report->warnings.begin(), report->warnings.end(), [&](const auto& w) {
      return w.code == WarningCode::kRadiusCapped && w.message.find(a) != std::string::npos &&
             w.message.find(b) != std::string::npos;
    });
  };
  EXPECT_TRUE(warned("r_min", "scanner metadata"));
  const StageReport& thinning = report->stages.back();
  ASSERT_EQ(thinning.name, "simplification");
  EXPECT_EQ(thinning.parameters.at("simplification.radii_capped"), 1);
  EXPECT_LE(thinning.parameters.at("simplification.spacing_mm"),
            10 * nb.parameters.at("neighbourhoods.global_radius_mm") + 1e-6);
  EXPECT_TRUE(warned("r_s", "scanner metadata"));
  ExpectStillPlane(cloud, 0, 1e-4f);
}

TEST(DegenerateClouds, CoordinatesOfTenKilometresKeepThePlane) {
  // At 1e7 mm a float resolves 1 mm, so the grid uses a 2 mm step (exactly representable).
  PointCloud cloud = Grid(30, 30, 2.0f, 1e7f, -1e7f, 1e7f);
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  ExpectStillPlane(cloud, 1e7f, 1.0f);
}

TEST(DegenerateClouds, DuplicatesMixedIntoARealScan) {
  auto sim = sim::Simulate(sim::Part::kSphere, sim::FrontalSensor(sim::Part::kSphere), 7);
  PointCloud& cloud = sim.cloud;
  // Every fifth point twice more, appended as a scanner that repeats samples would.
  const size_t n = cloud.size();
  for (int copy = 0; copy < 2; ++copy) {
    for (size_t i = 0; i < n; i += 5) {
      AddPoint(cloud, cloud.x[i], cloud.y[i], cloud.z[i], cloud.scan[i]);
      cloud.scanline.push_back(cloud.scanline[i]);
    }
  }
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  // Kept points stay on the sphere within the noise the frontal sensor adds (σ = 0.01 mm).
  size_t kept = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.removed(i)) continue;
    ++kept;
    EXPECT_LT(sim::DistanceToSurface(sim::Part::kSphere, cloud.point(i).cast<double>()), 0.1)
        << "point " << i;
  }
  EXPECT_GT(kept, n / 10);
}

TEST(DegenerateClouds, ScanlinesOutOfOrder) {
  // The grid stored column by column, and its scanline ids a permutation of the rows: neither
  // the array order nor the ids follow the sweep.
  PointCloud grid = Grid(30, 30, 0.5f);
  std::vector<uint32_t> ids(30);
  std::iota(ids.begin(), ids.end(), 0u);
  std::shuffle(ids.begin(), ids.end(), std::mt19937(3));
  PointCloud cloud;
  cloud.scans = grid.scans;
  for (int c = 0; c < 30; ++c) {
    for (int r = 0; r < 30; ++r) {
      const size_t i = static_cast<size_t>(r * 30 + c);
      AddPoint(cloud, grid.x[i], grid.y[i], grid.z[i]);
      cloud.scanline.push_back(ids[grid.scanline[i]]);
    }
  }
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  ExpectStillPlane(cloud, 0, 1e-4f);
}

TEST(DegenerateClouds, TwoScansOfTheSamePoints) {
  // Both scans sampled exactly the same grid: the merge compares identical positions.
  PointCloud cloud = Grid(30, 30, 0.5f);
  cloud.scans.push_back(TopViewScan("again", 0.5));
  const size_t n = cloud.size();
  for (size_t i = 0; i < n; ++i) {
    AddPoint(cloud, cloud.x[i], cloud.y[i], cloud.z[i], 1);
    cloud.scanline.push_back(cloud.scanline[i]);
  }
  auto report = RunAllStages(cloud);
  ASSERT_TRUE(report.ok()) << report.status();
  ExpectFinite(cloud);
  ExpectStillPlane(cloud, 0, 1e-4f);
}

}  // namespace
}  // namespace scanprep
