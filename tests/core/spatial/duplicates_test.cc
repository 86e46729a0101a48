// SPDX-License-Identifier: Apache-2.0
// Points that coincide across scans (a scan sent twice): counted in the report with a warning,
// against a count taken by brute force over the scans' positions.
#include <algorithm>
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

double ResolutionEdge(const PointCloud& cloud);

// The ground truth: points within ε (the resolution cube's edge) of the first point of a cube of
// a lower-numbered scan, by a sweep over those first points sorted by x.
uint64_t CoincidentAcrossScans(const PointCloud& cloud) {
  const double edge = ResolutionEdge(cloud);
  std::set<std::tuple<uint32_t, int64_t, int64_t, int64_t>> seen;
  std::vector<std::pair<float, uint32_t>> firsts;  // (x, index)
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (seen.insert({cloud.scan[i], int64_t(std::floor(double(cloud.x[i]) / edge)),
                     int64_t(std::floor(double(cloud.y[i]) / edge)),
                     int64_t(std::floor(double(cloud.z[i]) / edge))})
            .second) {
      firsts.push_back({cloud.x[i], static_cast<uint32_t>(i)});
    }
  }
  std::sort(firsts.begin(), firsts.end());
  uint64_t count = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    auto it = std::lower_bound(firsts.begin(), firsts.end(),
                               std::pair<float, uint32_t>{float(cloud.x[i] - edge), 0});
    for (; it != firsts.end() && it->first <= cloud.x[i] + edge; ++it) {
      const uint32_t j = it->second;
      const Eigen::Vector3d d = (cloud.point(i) - cloud.point(j)).cast<double>();
      if (cloud.scan[j] < cloud.scan[i] && d.norm() <= edge) {
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

// The same sensor and pose, other noise: a few points fall within the resolution by chance,
// counted, but too few to be a repeated scan.
TEST(CoincidentAcrossScans, DistinctScansAreNoRepeat) {
  PointCloud cloud = Scans({7, 8, 9});
  const uint64_t truth = CoincidentAcrossScans(cloud);
  ASSERT_LT(truth, cloud.size() / 30);
  const PipelineReport report = RunNeighbourhoods(cloud);
  EXPECT_EQ(report.points_coincident_across_scans, truth);
  EXPECT_FALSE(WarnsAboutCoincidence(report));
}

// Issue 39, finding 4: one scan sent again after a re-export (every coordinate moved by 1 ULP,
// 1e-5 or 1e-4 mm, with a random sign) is a repeated scan like an exact copy; found with the
// resolution ε = u/100 = 3e-4 mm. Control: the same scan moved by a third of its point spacing
// across the surface (another sampling of the same part) is not.
TEST(CoincidentAcrossScans, AReExportedScanIsARepeat) {
  const PointCloud base =
      sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 7).cloud;
  ASSERT_NEAR(ResolutionEdge(base), 3e-4, 1e-9);
  const double spacing = base.scans.front().point_spacing;
  for (const double moved : {0.0, 1e-5, 1e-4, spacing / 3}) {
    SCOPED_TRACE(moved);
    PointCloud cloud;
    cloud.kind = ScannerKind::kLine;
    for (const char* id : {"scan", "again"}) {
      cloud.scans.push_back(base.scans.front());
      cloud.scans.back().id = id;
    }
    AppendAsScan(base, 0, cloud, [](size_t) { return true; });
    AppendAsScan(base, 1, cloud, [](size_t) { return true; });
    std::mt19937 rng(11);
    for (size_t i = base.size(); i < cloud.size(); ++i) {
      for (float* v : {&cloud.x[i], &cloud.y[i], &cloud.z[i]}) {
        const float away = rng() % 2 ? HUGE_VALF : -HUGE_VALF;
        *v = moved == 0 ? std::nextafter(*v, away) : *v + float(rng() % 2 ? moved : -moved);
      }
      if (moved > 1e-3) cloud.z[i] = base.z[i - base.size()], cloud.y[i] = base.y[i - base.size()];
    }
    const uint64_t truth = CoincidentAcrossScans(cloud);
    const PipelineReport report = RunNeighbourhoods(cloud);
    EXPECT_EQ(report.points_coincident_across_scans, truth);
    if (moved > 1e-3) {
      EXPECT_LT(truth, base.size() / 100);
      EXPECT_FALSE(WarnsAboutCoincidence(report));
    } else {
      EXPECT_GT(truth, base.size() * 9 / 10);
      EXPECT_TRUE(WarnsAboutCoincidence(report));
    }
  }
}

// A stated u a thousand times the point spacing (a unit slip in the metadata, no spacing stated)
// makes ε ten spacings: every scan's own points lie that close, so another sampling of the
// same surface nearby says nothing about a repeat, and is not called one; an exact copy still is
// (compared by position). The control: the same scans with their own u.
TEST(CoincidentAcrossScans, AResolutionTheScanDoesNotResolveFindsNoRepeat) {
  const PointCloud base =
      sim::Simulate(Part::kBoxWithBore, sim::FrontalSensor(Part::kBoxWithBore), 7).cloud;
  const double spacing = base.scans.front().point_spacing;
  for (const bool copy : {false, true}) {
    for (const double u : {base.scans.front().uncertainty, 1000 * spacing}) {
      SCOPED_TRACE(testing::Message() << "copy " << copy << ", u " << u);
      PointCloud cloud;
      cloud.kind = ScannerKind::kLine;
      for (const char* id : {"scan", "other"}) {
        cloud.scans.push_back(base.scans.front());
        cloud.scans.back().id = id;
        cloud.scans.back().uncertainty = u;
        cloud.scans.back().point_spacing = cloud.scans.back().scanline_spacing = 0;
      }
      AppendAsScan(base, 0, cloud, [](size_t) { return true; });
      AppendAsScan(base, 1, cloud, [](size_t) { return true; });
      if (!copy) {
        for (size_t i = base.size(); i < cloud.size(); ++i) cloud.x[i] += float(spacing / 3);
      }
      ASSERT_NEAR(ResolutionEdge(cloud), u / 100, 1e-12);
      const PipelineReport report = RunNeighbourhoods(cloud);
      EXPECT_EQ(WarnsAboutCoincidence(report), copy);
    }
  }
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
double ResolutionEdge(const PointCloud& cloud) {
  double edge = HUGE_VAL;
  for (const ScanMeta& scan : cloud.scans) {
    edge = std::min(edge, scan.uncertainty / 100);
    for (const double spacing : {scan.point_spacing, scan.scanline_spacing}) {
      if (spacing > 0) edge = std::min(edge, spacing / 8);
    }
  }
  return edge;
}

uint64_t SharingAResolutionCube(const PointCloud& cloud) {
  const double edge = ResolutionEdge(cloud);
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
