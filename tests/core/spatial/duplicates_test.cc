// SPDX-License-Identifier: Apache-2.0
// Points that coincide across scans (a scan sent twice): counted in the report with a warning,
// against a count taken by brute force over the scans' positions.
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"

namespace scanprep {
namespace {

using sim::Part;

uint64_t SharingAResolutionCube(const PointCloud& cloud);

// The ground truth: points whose exact position a lower-numbered scan holds.
uint64_t CoincidentAcrossScans(const PointCloud& cloud) {
  using Position = std::tuple<float, float, float>;
  std::vector<std::set<Position>> by_scan(cloud.scans.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    by_scan[cloud.scan[i]].insert({cloud.x[i], cloud.y[i], cloud.z[i]});
  }
  uint64_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Position p{cloud.x[i], cloud.y[i], cloud.z[i]};
    for (uint32_t s = 0; s < cloud.scan[i]; ++s) {
      if (by_scan[s].contains(p)) {
        ++count;
        break;
      }
    }
  }
  return count;
}

// The points of `from` for which `keep(i)` holds, appended to `to` as scan `scan`.
template <typename Keep>
void AppendAsScan(const PointCloud& from, uint32_t scan, PointCloud& to, Keep keep) {
  for (size_t i = 0; i < from.size(); ++i) {
    if (!keep(i)) continue;
    to.x.push_back(from.x[i]);
    to.y.push_back(from.y[i]);
    to.z.push_back(from.z[i]);
    to.scan.push_back(scan);
    to.scanline.push_back(from.scanline[i]);
  }
}

// `scans` simulated frontal scans of the box, each with its own noise seed (seeds[s]); the same
// seed twice is the same scan sent twice.
PointCloud Scans(const std::vector<uint64_t>& seeds) {
  PointCloud cloud;
  cloud.kind = ScannerKind::kLine;
  for (size_t s = 0; s < seeds.size(); ++s) {
    const PointCloud one =
        sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), seeds[s]).cloud;
    ScanMeta meta = one.scans.front();
    meta.id = absl::StrCat("scan", s);
    cloud.scans.push_back(meta);
    AppendAsScan(one, static_cast<uint32_t>(s), cloud, [](size_t) { return true; });
  }
  return cloud;
}

PipelineReport RunNeighbourhoods(PointCloud& cloud) {
  cloud.FinishLoading();
  PipelineOptions options;
  options.stages = {"neighbourhoods"};
  auto report = RunPipeline(cloud, options, CancelToken());
  EXPECT_TRUE(report.ok()) << report.status();
  return report.ok() ? *report : PipelineReport{};
}

bool WarnsAboutCoincidence(const PipelineReport& report) {
  for (const Warning& w : report.warnings) {
    if (w.code == WarningCode::kScanRepeated) return true;
  }
  return false;
}

TEST(CoincidentAcrossScans, OneScanSentAsThreeIsCountedAndWarned) {
  PointCloud cloud = Scans({7, 7, 7});
  const uint64_t truth = CoincidentAcrossScans(cloud);
  ASSERT_GT(truth, cloud.size() / 2);  // the fixture: two of three copies of every point
  const PipelineReport report = RunNeighbourhoods(cloud);
  EXPECT_EQ(report.points_coincident_across_scans, truth);
  EXPECT_TRUE(WarnsAboutCoincidence(report));
}

TEST(CoincidentAcrossScans, DistinctScansCountNothing) {
  PointCloud cloud = Scans({7, 8, 9});  // the same sensor, other noise: no position repeats
  ASSERT_EQ(CoincidentAcrossScans(cloud), 0u);
  const PipelineReport report = RunNeighbourhoods(cloud);
  EXPECT_EQ(report.points_coincident_across_scans, 0u);
  EXPECT_FALSE(WarnsAboutCoincidence(report));
}

// Scan 1 repeats every third point of scan 0 among its own, scan 2 every fifth twice (within-scan
// duplicates too): each copy in a later scan counts once, whatever else holds the position.
TEST(CoincidentAcrossScans, PartialRepeatsAndWithinScanDuplicates) {
  const PointCloud base =
      sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 7).cloud;
  const PointCloud other =
      sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 8).cloud;
  PointCloud cloud;
  cloud.kind = ScannerKind::kLine;
  for (int s = 0; s < 3; ++s) {
    ScanMeta meta = base.scans.front();
    meta.id = absl::StrCat("scan", s);
    cloud.scans.push_back(meta);
  }
  AppendAsScan(base, 0, cloud, [](size_t) { return true; });
  AppendAsScan(other, 1, cloud, [](size_t i) { return i % 2 == 0; });
  AppendAsScan(base, 1, cloud, [](size_t i) { return i % 3 == 0; });
  AppendAsScan(base, 2, cloud, [](size_t i) { return i % 5 == 0; });
  AppendAsScan(base, 2, cloud, [](size_t i) { return i % 5 == 0; });
  AppendAsScan(other, 2, cloud, [](size_t i) { return i % 2 == 1; });
  const uint64_t truth = CoincidentAcrossScans(cloud);
  ASSERT_GT(truth, 0u);
  const PipelineReport report = RunNeighbourhoods(cloud);
  EXPECT_EQ(report.points_coincident_across_scans, truth);
  EXPECT_TRUE(WarnsAboutCoincidence(report));
  // Only the points within one scan's resolution cube are collapsed: the exact copies, and the
  // pairs of scan 1's two noisy simulations of one sampling grid that fell within u/100.
  EXPECT_EQ(report.stages.front().parameters.at("neighbourhoods.duplicates_collapsed"),
            double(SharingAResolutionCube(cloud)));
  EXPECT_GE(SharingAResolutionCube(cloud), (base.size() + 4) / 5);
}

// The ground truth of what is collapsed: points whose cube of edge u/100 (u the scans' finest
// uncertainty, at most an eighth of a stated spacing: core/spatial/duplicates.h) already holds
// a point of their scan.
uint64_t SharingAResolutionCube(const PointCloud& cloud) {
  double edge = HUGE_VAL;
  for (const ScanMeta& scan : cloud.scans) {
    edge =
        std::min({edge, scan.uncertainty / 100, scan.point_spacing / 8, scan.scanline_spacing / 8});
  }
  std::set<std::tuple<uint32_t, int64_t, int64_t, int64_t>> seen;
  uint64_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    count += !seen.insert({cloud.scan[i], int64_t(std::floor(double(cloud.x[i]) / edge)),
                           int64_t(std::floor(double(cloud.y[i]) / edge)),
                           int64_t(std::floor(double(cloud.z[i]) / edge))})
                  .second;
  }
  return count;
}

// A cluster of 20,000 distinct points within 1e-4 mm (a sensor's zero-range returns) beside a
// plane of one scan: collapsed to the points its cubes hold, so no ball around it fills up; the
// control, the same cluster spread over 2 mm, keeps every point.
TEST(ResolutionCubes, ANearIdenticalClusterIsOneMeasurement) {
  for (const double spread : {1e-4, 2.0}) {
    PointCloud cloud =
        sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 9).cloud;
    std::mt19937 rng(4);
    std::uniform_real_distribution<double> jitter(0, spread);
    const size_t plane = cloud.size();
    for (int c = 0; c < 20'000; ++c) {
      cloud.x.push_back(static_cast<float>(1 + jitter(rng)));
      cloud.y.push_back(static_cast<float>(1 + jitter(rng)));
      cloud.z.push_back(static_cast<float>(20 + jitter(rng)));
      cloud.scan.push_back(0);
      cloud.scanline.push_back(0);
    }
    const uint64_t truth = SharingAResolutionCube(cloud);
    const PipelineReport report = RunNeighbourhoods(cloud);
    const double collapsed =
        report.stages.front().parameters.at("neighbourhoods.duplicates_collapsed");
    EXPECT_EQ(collapsed, double(truth)) << "spread " << spread;
    if (spread < 1e-3) {
      EXPECT_GT(collapsed, 19'000) << "u = " << cloud.scans[0].uncertainty;
    } else {
      EXPECT_LT(collapsed, 100) << plane;
    }
  }
}

}  // namespace
}  // namespace scanprep
