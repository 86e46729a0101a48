// SPDX-License-Identifier: Apache-2.0
// The wire side of scanner health (issue 32): ScanHeader.sensor_id is checked where the header's
// other fields are, and the core HealthReport reaches Report.health field by field.
#include <cmath>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "wire/convert.h"

namespace scanprep {
namespace {

absl::StatusOr<ScanMeta> MetaWithSensor(const std::string& sensor_id) {
  v1::ScanHeader scan;
  scan.set_scan_id("s");
  scan.set_sensor_id(sensor_id);
  return ScanMetaFromProto(scan, ScanFrame{}, "header.scans[2]");
}

TEST(SensorId, AValidIdReachesTheScanMeta) {
  const std::string longest(64, 'a');
  for (const std::string& id : {std::string("cell3-left_A.1:cam"), longest, std::string()}) {
    const auto meta = MetaWithSensor(id);
    ASSERT_TRUE(meta.ok()) << meta.status();
    EXPECT_EQ(meta->sensor_id, id);
  }
}

TEST(SensorId, TheClientsUnmeasuredCountReachesTheScanMeta) {
  v1::ScanHeader scan;
  scan.set_points_unmeasured(42);
  const auto meta = ScanMetaFromProto(scan, ScanFrame{}, "header.scans[0]");
  ASSERT_TRUE(meta.ok()) << meta.status();
  EXPECT_EQ(meta->points_invalid, 42u);
}

TEST(SensorId, ABadIdIsRefusedNamingTheField) {
  for (const std::string& id :
       {std::string(65, 'a'), std::string("cell 3"), std::string("a|b"), std::string("x\"y"),
        std::string("caf\xc3\xa9"), std::string("a\nb")}) {
    const auto meta = MetaWithSensor(id);
    ASSERT_FALSE(meta.ok()) << id;
    EXPECT_EQ(meta.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(meta.status().message()),
                ::testing::StartsWith("header.scans[2].sensor_id: "));
  }
}

// A hand-made report: every field lands in its proto field, the pair is named by its scans'
// ids, and the unconstrained components by name.
TEST(HealthToProto, EveryFieldReachesTheReport) {
  PipelineReport report;
  HealthReport& health = report.health.emplace();
  ScanHealth a;
  a.scan = 0;
  a.scan_id = "top";
  a.sensor_id = "cell3-left";
  a.points = 1000;
  a.noise_mm = 0.012;
  a.noise_to_uncertainty = 1.2;
  a.outlier_share = 0.01;
  a.merged_share = 0.2;
  a.invalid_share = 0.03;
  a.viewing_angle_deg = std::array<double, 3>{5, 20, 60};
  ScanHealth b;  // nothing measured
  b.scan = 1;
  b.scan_id = "side";
  b.sensor_id = "cell3-right";
  b.points = 500;
  health.scans = {a, b};
  PairHealth pair;
  pair.fixed = 0;
  pair.moving = 1;
  pair.overlap_points = 321;
  pair.residual_median_mm = -0.004;
  pair.residual_spread_mm = 0.011;
  pair.centre = {1, 2, 3};
  pair.translation_mm = {0.002, 0, -0.005};
  pair.rotation_deg = {0.01, 0.02, 0};
  pair.translation_se_mm = {0.0001, 0.004, 0.0002};
  pair.rotation_se_deg = {0.001, 0.002, std::numeric_limits<double>::infinity()};
  pair.constrained = {true, false, true, true, true, false};
  pair.note = "too flat to constrain ty, rz";
  health.pairs = {pair};

  v1::Report out;
  ReportToProto(report, &out);
  ASSERT_TRUE(out.has_health());
  ASSERT_EQ(out.health().scans_size(), 2);
  const v1::ScanHealth& s = out.health().scans(0);
  EXPECT_EQ(s.scan_id(), "top");
  EXPECT_EQ(s.sensor_id(), "cell3-left");
  EXPECT_EQ(s.points(), 1000u);
  EXPECT_DOUBLE_EQ(s.noise_mm(), 0.012);
  EXPECT_DOUBLE_EQ(s.noise_to_uncertainty(), 1.2);
  EXPECT_DOUBLE_EQ(s.outlier_share(), 0.01);
  EXPECT_DOUBLE_EQ(s.merged_share(), 0.2);
  EXPECT_DOUBLE_EQ(s.invalid_share(), 0.03);
  EXPECT_THAT(s.viewing_angle_percentiles_deg(), ::testing::ElementsAre(5, 20, 60));
  const v1::ScanHealth& unmeasured = out.health().scans(1);
  EXPECT_FALSE(unmeasured.has_noise_mm());
  EXPECT_FALSE(unmeasured.has_noise_to_uncertainty());
  EXPECT_FALSE(unmeasured.has_outlier_share());
  EXPECT_FALSE(unmeasured.has_merged_share());
  EXPECT_TRUE(unmeasured.viewing_angle_percentiles_deg().empty());

  ASSERT_EQ(out.health().pairs_size(), 1);
  const v1::PairHealth& p = out.health().pairs(0);
  EXPECT_EQ(p.fixed_scan_id(), "top");
  EXPECT_EQ(p.moving_scan_id(), "side");
  EXPECT_EQ(p.fixed_sensor_id(), "cell3-left");
  EXPECT_EQ(p.moving_sensor_id(), "cell3-right");
  EXPECT_EQ(p.overlap_points(), 321u);
  EXPECT_DOUBLE_EQ(p.residual_median_mm(), -0.004);
  EXPECT_DOUBLE_EQ(p.residual_spread_mm(), 0.011);
  EXPECT_DOUBLE_EQ(p.translation_mm().x(), 0.002);
  EXPECT_DOUBLE_EQ(p.translation_mm().z(), -0.005);
  EXPECT_DOUBLE_EQ(p.rotation_deg().y(), 0.02);
  EXPECT_DOUBLE_EQ(p.centre().z(), 3);
  EXPECT_DOUBLE_EQ(p.translation_se_mm().x(), 0.0001);
  EXPECT_DOUBLE_EQ(p.translation_se_mm().y(), 0.004);
  EXPECT_DOUBLE_EQ(p.rotation_se_deg().y(), 0.002);
  EXPECT_TRUE(std::isinf(p.rotation_se_deg().z()));
  EXPECT_THAT(p.unconstrained(), ::testing::ElementsAre("ty", "rz"));
  EXPECT_EQ(p.note(), "too flat to constrain ty, rz");
}

TEST(HealthToProto, NoHealthStageNoHealthMessage) {
  v1::Report out;
  ReportToProto(PipelineReport{}, &out);
  EXPECT_FALSE(out.has_health());
}

}  // namespace
}  // namespace scanprep
