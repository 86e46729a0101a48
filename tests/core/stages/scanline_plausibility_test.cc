// SPDX-License-Identifier: Apache-2.0
// Scanline indices that hold areas, not profiles, are named (SCANLINES_IMPLAUSIBLE): every point
// of a grid on scanline 0; and not named where they are profiles: the same grid by rows, rows ten
// times further apart than their points (each point's k nearest all on its own line, but along
// one direction), and simulated laser-line scans of a part with edges and a bore.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "core/stages/warning.h"
#include "tests/support/metrology_job.h"

namespace scanprep::testing {
namespace {

// side × side points, `row_gap` mm between rows and 0.1 mm along them, noise 0.005 mm.
PointCloud Grid(int side, double row_gap) {
  PointCloud cloud;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 0.005);
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      cloud.x.push_back(static_cast<float>(0.1 * col));
      cloud.y.push_back(static_cast<float>(row_gap * row));
      cloud.z.push_back(static_cast<float>(noise(rng)));
      cloud.scanline.push_back(row);
    }
  }
  cloud.scans.push_back(ScanMeta{
      .id = "grid", .scanline_spacing = row_gap, .uncertainty = 0.005, .point_spacing = 0.1});
  cloud.kind = ScannerKind::kLine;
  cloud.FinishLoading();
  return cloud;
}

// The SCANLINES_IMPLAUSIBLE warnings of the neighbourhoods stage on `cloud`.
std::vector<Warning> Implausible(PointCloud cloud) {
  PipelineOptions options;
  options.stages = {"neighbourhoods"};
  auto report = RunPipeline(cloud, options, CancelToken());
  EXPECT_TRUE(report.ok()) << report.status();
  std::vector<Warning> found;
  if (!report.ok()) return found;
  for (const Warning& w : report->warnings) {
    if (w.code == WarningCode::kScanlinesImplausible) found.push_back(w);
  }
  return found;
}

TEST(ScanlinePlausibility, EveryPointOnOneScanlineIsNamed) {
  PointCloud cloud = Grid(150, 0.1);
  std::fill(cloud.scanline.begin(), cloud.scanline.end(), 0u);
  const std::vector<Warning> found = Implausible(cloud);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].params.at("scan"), "grid");
  EXPECT_GT(std::stod(found[0].params.at("area_share")), 0.9);
}

TEST(ScanlinePlausibility, ProfilesAreNotNamed) {
  EXPECT_TRUE(Implausible(Grid(150, 0.1)).empty());  // the control: the same grid by rows
  EXPECT_TRUE(Implausible(Grid(150, 1.0)).empty());  // rows far apart: k nearest on one line
  for (const sim::Part part : {sim::Part::kSteppedBlock, sim::Part::kBoxWithBore}) {
    const sim::SimulatedCloud sim = SimulateScan(part, 0.01, 100000, 9);
    EXPECT_TRUE(Implausible(WithUserMetadata(sim, 0.01)).empty()) << int(part);
  }
}

}  // namespace
}  // namespace scanprep::testing
