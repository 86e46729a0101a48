// SPDX-License-Identifier: Apache-2.0
// All ten Stanford bunny range scans through the service, registered by the server with the
// bun.conf poses: one bunny must come back, not ten.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "core/io/ply.h"
#include "tests/server/bunny_job.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/kdtree.h"
#include "tests/support/test_data.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;

// Median distance from the points of `scan` in `probe` to the nearest point of the other scans
// of `reference`.
double MedianDistanceToOtherScans(const PointCloud& probe, const PointCloud& reference,
                                  uint32_t scan) {
  PointCloud others;
  for (size_t i = 0; i < reference.size(); ++i) {
    if (reference.scan[i] == scan) continue;
    others.x.push_back(reference.x[i]);
    others.y.push_back(reference.y[i]);
    others.z.push_back(reference.z[i]);
  }
  KdTree tree(others);
  std::vector<float> d;
  for (size_t i = 0; i < probe.size(); i += 3) {  // every third point is plenty for a median
    if (probe.scan[i] != scan) continue;
    const float q[3] = {probe.x[i], probe.y[i], probe.z[i]};
    uint32_t idx;
    float dist_sq;
    tree.Knn(q, 1, &idx, &dist_sq);
    d.push_back(std::sqrt(dist_sq));
  }
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

TEST(Bunny, TenScansRegisterIntoOneBunny) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  const fs::path dir = data / "stanford_bunny_range_scans";
  BunnyJob job = LoadBunny(dir);
  job.header.mutable_options()->add_stages("outliers");
  ASSERT_EQ(job.points.size(), 362'272u);

  InProcessServer server;
  auto result = server.Client().Process(job.header, job.points);
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::Report& report = result->report;
  EXPECT_EQ(report.job_id(), "bunny");
  EXPECT_EQ(report.points_received(), 362'272u);
  EXPECT_EQ(report.points_invalid(), 0u);
  EXPECT_EQ(report.points_processed(), 362'272u);
  // The surface test pulls in the normals, listed before the stage that needed them.
  ASSERT_EQ(report.stages_size(), 3);
  EXPECT_EQ(report.stages(0).name(), "neighbourhoods");
  EXPECT_EQ(report.stages(1).name(), "normals");
  EXPECT_EQ(report.stages(2).name(), "outliers");
  EXPECT_EQ(report.stages(2).points_in(), 362'272u);
  const uint64_t kept = report.stages(2).points_out();
  EXPECT_LT(kept, 362'272u);       // raw range scans do have stray points
  EXPECT_GT(kept, 0.9 * 362'272);  // but few
  EXPECT_EQ(report.points_returned(), kept);
  EXPECT_EQ(result->cloud.size(), kept);
  // Thresholds are per scan, one per bunny scan, and in mm: the grid spacing is about 0.5 mm.
  for (int s = 0; s < 10; ++s) {
    const double t =
        report.stages(2).parameters().at("outliers.threshold_mm.scan" + std::to_string(s));
    EXPECT_GT(t, 0.3);
    EXPECT_LT(t, 5.0);
  }

  // Back in metres: the bunny is about 0.155 × 0.15 × 0.12 m.
  const auto [min_x, max_x] = std::minmax_element(result->cloud.x.begin(), result->cloud.x.end());
  EXPECT_GT(*max_x - *min_x, 0.12);
  EXPECT_LT(*max_x - *min_x, 0.25);

  // Round trip through a PLY file, then the registration check on what was written.
  const fs::path out = fs::path(::testing::TempDir()) / "bunny_registered.ply";
  ASSERT_TRUE(io::WritePly(out, result->cloud).ok());
  std::vector<std::string> ply_warnings;
  auto written = io::ReadPly(out, ply_warnings);
  ASSERT_TRUE(written.ok()) << written.status();
  ASSERT_EQ(written->size(), kept);
  for (uint32_t s = 0; s < 10; ++s) {
    const double median = MedianDistanceToOtherScans(*written, *written, s);
    RecordProperty(std::string("median_mm_") + kScans[s], std::to_string(median * 1000));
    EXPECT_LT(median, 0.001) << kScans[s];
  }
  // Control: bun045 left in its own frame sits centimetres away from the rest.
  const double unregistered = MedianDistanceToOtherScans(job.points, *written, 1);
  RecordProperty("median_mm_bun045_unregistered", std::to_string(unregistered * 1000));
  EXPECT_GT(unregistered, 0.005);
}

}  // namespace
}  // namespace scanprep::testing
