// SPDX-License-Identifier: Apache-2.0
// `scanprep health` and `process --health` print the report's health (issue 32) from a
// hand-made Report: each value in the unit its header names, unset values and unconstrained
// components as "-", never as a 0 that would read as "no misalignment".
#include <limits>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/health_table.h"

namespace scanprep::client {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace v1 = ::scanprep::v1;

std::string Printed(const v1::Report& report) {
  std::ostringstream out;
  PrintHealth(out, report);
  return out.str();
}

// The line that starts with `first` (a row's first cell), split on blanks.
std::vector<std::string> Row(const std::string& text, const std::string& first) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::vector<std::string> cells;
    for (std::string w; words >> w;) cells.push_back(w);
    if (!cells.empty() && cells[0] == first) return cells;
  }
  return {};
}

v1::Report TwoScansOnePair() {
  v1::Report report;
  v1::HealthReport& health = *report.mutable_health();
  v1::ScanHealth& left = *health.add_scans();
  left.set_scan_id("left");
  left.set_sensor_id("cell3-left");
  left.set_points(40256);
  left.set_noise_mm(0.0123);
  left.set_noise_to_uncertainty(1.23);
  left.set_outlier_share(0.0125);
  left.set_merged_share(0.25);
  left.set_invalid_share(0.001);
  for (double deg : {12.4, 35.0, 61.6}) left.add_viewing_angle_percentiles_deg(deg);
  v1::ScanHealth& right = *health.add_scans();  // nothing measured but its size
  right.set_scan_id("right");
  right.set_points(7);
  v1::PairHealth& pair = *health.add_pairs();
  pair.set_fixed_scan_id("left");
  pair.set_moving_scan_id("right");
  pair.set_overlap_points(5321);
  pair.set_residual_median_mm(-0.0042);
  pair.set_residual_spread_mm(0.0105);
  pair.mutable_translation_mm()->set_x(0.002);
  pair.mutable_translation_mm()->set_y(-0.0155);
  pair.mutable_rotation_deg()->set_x(0.0125);
  pair.mutable_rotation_deg()->set_z(-0.05);
  pair.mutable_translation_se_mm()->set_x(0.0001);
  pair.mutable_translation_se_mm()->set_y(0.00035);
  pair.mutable_translation_se_mm()->set_z(0.0042);
  pair.mutable_rotation_se_deg()->set_x(0.0004);
  pair.mutable_rotation_se_deg()->set_y(std::numeric_limits<double>::infinity());
  pair.mutable_rotation_se_deg()->set_z(0.002);
  pair.add_unconstrained("tz");
  pair.add_unconstrained("ry");
  pair.set_note("too flat to constrain tz, ry");
  return report;
}

TEST(HealthTable, ScanRowsInTheirHeadersUnits) {
  const std::string text = Printed(TwoScansOnePair());
  // noise mm, noise/u, outlier %, merged %, invalid %, viewing angle p10/p50/p90 in degrees.
  EXPECT_THAT(Row(text, "left"),
              ::testing::ElementsAre("left", "cell3-left", "40256", "0.0123", "1.23", "1.25",
                                     "25.00", "0.10", "12/35/62"));
  EXPECT_THAT(Row(text, "right"),
              ::testing::ElementsAre("right", "-", "7", "-", "-", "-", "-", "0.00", "-"));
}

TEST(HealthTable, PairRowInMicrometresAndDegreesWithUnconstrainedAsDash) {
  const std::string text = Printed(TwoScansOnePair());
  // After the pairs' header: the scans' table has a row starting with "left" too.
  const std::vector<std::string> pair =
      Row(text.substr(text.find("health of overlapping pairs")), "left");
  ASSERT_GE(pair.size(), 10u) << text;
  EXPECT_EQ(pair[1], "right");
  EXPECT_EQ(pair[2], "5321");
  EXPECT_EQ(pair[3], "-4.20");              // median, µm
  EXPECT_EQ(pair[4], "10.50");              // spread, µm
  EXPECT_EQ(pair[5], "2.00/-15.50/-");      // translation µm; tz unconstrained
  EXPECT_EQ(pair[6], "0.10/0.35/4.20");     // its standard errors, µm, tz's too
  EXPECT_EQ(pair[7], "0.0125/-/-0.0500");   // rotation deg; ry unconstrained
  EXPECT_EQ(pair[8], "0.0004/inf/0.0020");  // nothing at all along ry
  EXPECT_THAT(text, HasSubstr("tz,ry (too flat to constrain tz, ry)"));
}

// The right edge of `cell` in `line` (a right-aligned column ends there).
size_t EndOf(const std::string& line, const std::string& cell) {
  return line.find(cell) + cell.size();
}

TEST(HealthTable, LongScanIdsKeepTheColumnsAligned) {
  v1::Report report = TwoScansOnePair();
  report.mutable_health()->mutable_scans(0)->set_scan_id("happyStandRight_264");  // 19 bytes
  std::istringstream lines(Printed(report));
  std::string title, header, row;
  std::getline(lines, title);
  std::getline(lines, header);
  std::getline(lines, row);
  ASSERT_EQ(row.rfind("happyStandRight_264 ", 0), 0u) << row;
  EXPECT_EQ(EndOf(row, "40256"), EndOf(header, "points")) << header << "\n" << row;
  EXPECT_EQ(EndOf(row, "0.0123"), EndOf(header, "noise_mm")) << header << "\n" << row;
}

TEST(HealthTable, NoPairsAndNoHealthAreSaid) {
  v1::Report one = TwoScansOnePair();
  one.mutable_health()->clear_pairs();
  EXPECT_THAT(Printed(one), HasSubstr("overlapping pairs: none"));
  EXPECT_THAT(Printed(v1::Report()), HasSubstr("health: not measured"));
  EXPECT_THAT(Printed(v1::Report()), Not(HasSubstr("noise_mm")));
}

// The motion registration applied, after the pairs (measured before it): µm and degrees as the
// headers say, each scan's role, a residual the report leaves unset as "-".
TEST(HealthTable, RegistrationRowsInMicrometresAndDegreesWithTheirRole) {
  v1::Report report = TwoScansOnePair();
  EXPECT_THAT(Printed(report), Not(HasSubstr("registration")));  // the stage did not run
  v1::ScanRegistration& left = *report.add_registration();
  left.set_scan_id("left");
  left.set_reference(true);
  left.set_constrained_directions(0);
  left.set_residual_before_mm(0.0121);
  left.set_residual_after_mm(0.0102);
  v1::ScanRegistration& right = *report.add_registration();
  right.set_scan_id("right");
  right.mutable_translation_mm()->set_x(-0.0021);
  right.mutable_translation_mm()->set_z(0.01234);
  right.mutable_rotation_deg()->set_y(0.0125);
  right.set_constrained_directions(4);
  right.set_residual_before_mm(0.0205);
  right.set_iterations(2);
  const std::string text = Printed(report);
  EXPECT_THAT(text, HasSubstr("measured before registration"));
  const std::string table = text.substr(text.find("registration (the motion"));
  EXPECT_THAT(Row(table, "left"),
              ::testing::ElementsAre("left", "reference", "0.00/0.00/0.00", "0.0000/0.0000/0.0000",
                                     "0", "12.10", "10.20", "0"));
  EXPECT_THAT(Row(table, "right"),
              ::testing::ElementsAre("right", "moved", "-2.10/0.00/12.34", "0.0000/0.0125/0.0000",
                                     "4", "20.50", "-", "2"));
  report.mutable_registration(1)->set_bound_exceeded(true);
  EXPECT_EQ(Row(Printed(report).substr(text.find("registration (the motion")), "right")[1],
            "put-back");
}

}  // namespace
}  // namespace scanprep::client
