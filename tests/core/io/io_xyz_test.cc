// SPDX-License-Identifier: Apache-2.0
// XYZ text reader: separators, comments, PTS counts, errors, laser-profile splitting, and the
// Cognex laser-line scan from the data README.
#include <algorithm>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/io/xyz.h"
#include "tests/support/test_data.h"

namespace scanprep::io {
namespace {

absl::StatusOr<PointCloud> ParseText(const std::string& text, double profile_gap = 0.0) {
  std::istringstream in(text);
  std::vector<std::string> warnings;
  return ReadXyz(in, "points.xyz", warnings, profile_gap);
}

TEST(Xyz, AcceptsBlanksCommasCommentsAndExtraColumns) {
  absl::StatusOr<PointCloud> cloud = ParseText(
      "# header comment\r\n"
      "1 2 3\r\n"
      "\r\n"
      "  4.5,\t-6e-1 , +7   # trailing comment\n"
      "8,9,10,255,0,0\n"
      "\n");
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->x, (std::vector<float>{1.f, 4.5f, 8.f}));
  EXPECT_EQ(cloud->y, (std::vector<float>{2.f, -0.6f, 9.f}));
  EXPECT_EQ(cloud->z, (std::vector<float>{3.f, 7.f, 10.f}));
  EXPECT_FALSE(cloud->has_scanlines());
  EXPECT_EQ(cloud->flags.size(), 3u);
  EXPECT_EQ(cloud->scan, (std::vector<uint32_t>{0, 0, 0}));
  ASSERT_EQ(cloud->scans.size(), 1u);
  EXPECT_EQ(cloud->scans[0].id, "points");
}

TEST(Xyz, PtsCountLineIsCheckedAgainstThePoints) {
  absl::StatusOr<PointCloud> cloud = ParseText("2\n1 2 3 -1200 10 20 30\n4 5 6 -1100 10 20 30\n");
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->size(), 2u);
  cloud = ParseText("3\n1 2 3\n4 5 6\n");
  ASSERT_FALSE(cloud.ok());
  EXPECT_NE(cloud.status().message().find("first line declares 3 points but the file has 2"),
            std::string::npos)
      << cloud.status();
}

TEST(Xyz, ErrorsNameTheLineAndColumn) {
  absl::StatusOr<PointCloud> cloud = ParseText("1 2 3\n# c\n4 5\n");
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.status().message(), "points.xyz: line 3: expected x y z, found 2 value(s)");
  cloud = ParseText("1 2 3\n4 5x 6\n");
  EXPECT_EQ(cloud.status().message(), "points.xyz: line 2: column 2 '5x' is not a number");
  cloud = ParseText("1 2 1e300\n");
  EXPECT_EQ(cloud.status().message(), "points.xyz: line 1: column 3 is not a finite float");
  cloud = ParseText("1 2 3\n", -1.0);
  EXPECT_EQ(cloud.status().code(), absl::StatusCode::kInvalidArgument);
  std::vector<std::string> warnings;
  cloud = ReadXyz(std::filesystem::path("/nonexistent/points.xyz"), warnings);
  EXPECT_EQ(cloud.status().code(), absl::StatusCode::kNotFound);
}

TEST(Xyz, ProfileGapStartsANewScanlineAtEachJump) {
  // Three profiles along x at 0.5 spacing, separated by jumps of 10 in y.
  std::string text;
  for (int line = 0; line < 3; ++line) {
    for (int i = 0; i < 4 + line; ++i)
      text += std::to_string(0.5 * i) + " " + std::to_string(10 * line) + " 0\n";
  }
  absl::StatusOr<PointCloud> cloud = ParseText(text, 2.0);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 0, 0, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2}));
  cloud = ParseText(text, 0.4);  // smaller than the spacing: every point is its own line
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->scanline.back(), 14u);
}

TEST(XyzCognex, SixLaserProfilesInMillimetres) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  std::vector<std::string> warnings;
  absl::StatusOr<PointCloud> cloud =
      ReadXyz(data / "cognex_laser_line_scan" / "triangulated.xyz", warnings, 5.0);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 2628u);
  std::map<uint32_t, size_t> profile_sizes;
  for (uint32_t line : cloud->scanline) ++profile_sizes[line];
  ASSERT_EQ(profile_sizes.size(), 6u);
  // README: 291 to 518 points per profile.
  const auto [smallest, largest] =
      std::minmax_element(profile_sizes.begin(), profile_sizes.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; });
  EXPECT_EQ(smallest->second, 291u);
  EXPECT_EQ(largest->second, 518u);

  const double min[3] = {-72.343, -41.977, -758.84}, max[3] = {154.15, -6.4264, -698.5};
  const std::vector<float>* axes[3] = {&cloud->x, &cloud->y, &cloud->z};
  for (int a = 0; a < 3; ++a) {
    const auto [lo, hi] = std::minmax_element(axes[a]->begin(), axes[a]->end());
    EXPECT_NEAR(*lo, min[a], 1e-3);
    EXPECT_NEAR(*hi, max[a], 1e-3);
  }
  std::vector<float> steps;
  for (size_t i = 1; i < cloud->size(); ++i) {
    if (cloud->scanline[i] == cloud->scanline[i - 1])
      steps.push_back((cloud->point(i) - cloud->point(i - 1)).norm());
  }
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  EXPECT_NEAR(steps[steps.size() / 2], 0.40, 0.02);  // README: about 0.40 mm along each profile

  absl::StatusOr<PointCloud> plain =
      ReadXyz(data / "cognex_laser_line_scan" / "triangulated.xyz", warnings);
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_FALSE(plain->has_scanlines());
}

}  // namespace
}  // namespace scanprep::io
