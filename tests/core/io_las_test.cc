// SPDX-License-Identifier: Apache-2.0
// The LAS reader against files written here from the ASPRS specification's layouts: LAS 1.2
// format 0, LAS 1.4 format 6 (64-bit count, moved flags, wide scan angle), records with extra
// bytes, scanlines from the scan direction and edge flags, LAZ and damaged headers refused.
#include "core/io/las.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/io/scan_file.h"
#include "tests/support/las_file.h"

namespace scanprep::io {
namespace {

using ::testing::HasSubstr;

using testing::LasFile;
using testing::LasPoint;
using testing::PutAt;

absl::StatusOr<PointCloud> Read(const std::string& bytes, std::vector<std::string>& warnings) {
  return ReadLasBytes(bytes, "line.las", warnings);
}

// Point i's coordinate on `axis` in the file's frame: the cloud's origin plus its local float.
double World(const PointCloud& cloud, int axis, size_t i) {
  const std::vector<float>& local = axis == 0 ? cloud.x : axis == 1 ? cloud.y : cloud.z;
  return cloud.origin[axis] + local[i];
}

// Two sweeps of three points: the direction flips after the third, and the sixth is the last of
// its line; one more point after that edge starts a third line.
std::vector<LasPoint> Sweeps() {
  std::vector<LasPoint> p;
  for (int i = 0; i < 7; ++i) {
    p.push_back({.x = 1000 * i - 500,
                 .y = -250 * i,
                 .z = 7 * i,
                 .intensity = static_cast<uint16_t>(100 * i),
                 .direction = i >= 3,
                 .edge = i == 5,
                 .angle = -12.0 + 4 * i});
  }
  return p;
}

TEST(Las, Format0Version12ScaledCoordinatesIntensityAndScanlines) {
  std::vector<std::string> warnings;
  auto cloud = Read(LasFile(2, 0, Sweeps()), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 7u);
  for (int i = 0; i < 7; ++i) {
    EXPECT_NEAR(World(*cloud, 0, i), (1000 * i - 500) * 0.001 + 1000, 1e-6) << i;
    EXPECT_NEAR(World(*cloud, 1, i), -250 * i * 0.001 + 2000, 1e-6) << i;
    EXPECT_NEAR(World(*cloud, 2, i), 7 * i * 0.001 + 3000, 1e-6) << i;
    EXPECT_EQ(cloud->intensity[i], 100.0f * i);
  }
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 0, 1, 1, 1, 2}));
  EXPECT_EQ(cloud->scans.size(), 1u);
  EXPECT_EQ(cloud->scans[0].id, "line");
  EXPECT_THAT(warnings, ::testing::Contains(
                            HasSubstr("scan angle from -12.000 to 12.000 degrees, 3 scanlines")));
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("LAS carries no sensor origin")));
}

TEST(Las, Format6Version14WithExtraBytesAndTheWideScanAngle) {
  std::vector<std::string> warnings;
  auto cloud = Read(LasFile(4, 6, Sweeps(), /*record=*/30 + 12), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 7u);  // from the 64-bit count (the legacy one is 0)
  EXPECT_NEAR(World(*cloud, 0, 6), 5500 * 0.001 + 1000, 1e-6);
  EXPECT_EQ(cloud->intensity[6], 600.0f);
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 0, 1, 1, 1, 2}));
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("LAS 1.4, point format 6: scan angle from "
                                                      "-12.000 to 12.000")));
}

// A scanner that marks both ends of each line on the flight-line edge, with one scan direction:
// three lines of four points, not a line per marked point.
TEST(Las, EdgeFlagsOnBothEndsOfALineMakeOneLine) {
  std::vector<LasPoint> points;
  for (int i = 0; i < 12; ++i) {
    points.push_back(
        {.x = 1000 * i, .y = 0, .z = 0, .intensity = 1, .edge = i % 4 == 0 || i % 4 == 3});
  }
  std::vector<std::string> warnings;
  auto cloud = Read(LasFile(2, 0, points), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2}));
}

// Control for the scanline rule: flags that never change give no scanlines.
TEST(Las, OneSweepHasNoScanlines) {
  std::vector<LasPoint> points = Sweeps();
  for (LasPoint& p : points) p.direction = false, p.edge = false;
  std::vector<std::string> warnings;
  auto cloud = Read(LasFile(3, 3, points), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_FALSE(cloud->has_scanlines());
}

TEST(Las, EveryPointFormatReadsTheSameCoordinates) {
  for (int format = 0; format <= 10; ++format) {
    std::vector<std::string> warnings;
    auto cloud = Read(LasFile(format >= 6 ? 4 : 2, format, Sweeps()), warnings);
    ASSERT_TRUE(cloud.ok()) << format << ": " << cloud.status();
    EXPECT_NEAR(World(*cloud, 1, 3), -750 * 0.001 + 2000, 1e-6) << format;
    EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 0, 1, 1, 1, 2})) << format;
  }
}

TEST(Las, LazDamagedAndHostileFilesAreRefusedByName) {
  const std::string good = LasFile(2, 1, Sweeps());
  std::vector<std::string> warnings;
  ASSERT_TRUE(Read(good, warnings).ok());  // control

  std::string laz = good;
  laz[104] = static_cast<char>(1 | 0x80);
  auto status = Read(laz, warnings).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("LAZ-compressed; no LASzip decoder is packaged"));
  status = ReadLas(std::filesystem::path("/nonexistent/scan.laz"), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("laszip -i f.laz -o f.las"));

  std::string many = good;
  PutAt<uint32_t>(many, 107, 4'000'000'000u);
  status = Read(many, warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("header claims 4000000000 points of 28 bytes"));

  status = Read(good.substr(0, good.size() - 1), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("claims 7 points of 28 bytes from offset 281; the file "
                                          "holds 6"));

  std::string short_record = good;
  PutAt<uint16_t>(short_record, 105, 20);
  status = Read(short_record, warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("records of 20 bytes, format 1 needs at least 28"));

  std::string format = good;
  format[104] = 11;
  EXPECT_THAT(Read(format, warnings).status().message(), HasSubstr("point data format 11"));

  std::string version = good;
  version[25] = 5;
  EXPECT_THAT(Read(version, warnings).status().message(), HasSubstr("LAS version 1.5"));

  std::string scale = good;
  PutAt<double>(scale, 139, 0.0);
  EXPECT_THAT(Read(scale, warnings).status().message(), HasSubstr("y scale 0"));

  EXPECT_THAT(Read("LASX" + good.substr(4), warnings).status().message(),
              HasSubstr("no 'LASF' signature"));
}

// A header count below the records would leave points out unseen (issue 28: a count 1,000 below
// exited 0 and dropped 1,000 points); PLY and PCD refuse the same mismatch.
TEST(Las, HeaderCountBelowTheRecordsIsRefused) {
  std::vector<std::string> warnings;
  std::string legacy = LasFile(2, 0, Sweeps());
  PutAt<uint32_t>(legacy, 107, 6);
  auto status = Read(legacy, warnings).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("line.las: header claims 6 points of 20 bytes from "
                                          "offset 281 but the point data holds 140 bytes (7 "
                                          "points): wrong count (counts disagree)"));

  std::string wide = LasFile(4, 6, Sweeps());
  PutAt<uint64_t>(wide, 247, 5);
  EXPECT_THAT(Read(wide, warnings).status().message(),
              HasSubstr("header claims 5 points of 30 bytes"));

  // LAS 1.4's extended VLRs after the points end the point data: not extra records.
  std::string evlr = LasFile(4, 6, Sweeps()) + std::string(60, '\x01');
  PutAt<uint64_t>(evlr, 235, evlr.size() - 60);
  PutAt<uint32_t>(evlr, 243, 1);
  auto cloud = Read(evlr, warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->size(), 7u);
}

// A georeferenced file in metres (UTM-like, 5e5 m east, 5e6 m north): float alone keeps 3 cm
// there, the scale is 1 mm. Every coordinate comes back to half a unit of its scale, so a file
// written from it has the same integers.
TEST(Las, UtmCoordinatesKeepEveryUnitOfTheirScale) {
  std::vector<LasPoint> points;
  for (int i = 0; i < 200; ++i) {
    points.push_back(
        {.x = 37 * i - 3001, .y = 1 + (i * 7919) % 50'000, .z = -13 * i, .intensity = 0});
  }
  std::string bytes = LasFile(2, 1, points);
  const double offset[3] = {500'000.0, 5'000'000.0, 100.0};
  for (int k = 0; k < 3; ++k) PutAt<double>(bytes, 155 + 8 * k, offset[k]);
  std::vector<std::string> warnings;
  auto cloud = Read(bytes, warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t integers[3] = {points[i].x, points[i].y, points[i].z};
    for (int k = 0; k < 3; ++k) {
      const double truth = integers[k] * 0.001 + offset[k];
      ASSERT_NEAR(World(*cloud, k, i), truth, 0.5e-3) << i << " axis " << k;
      EXPECT_EQ(std::lround((World(*cloud, k, i) - offset[k]) / 0.001), integers[k]);
    }
  }
  // Local coordinates stay within the data's extent (50 m), not its distance from zero.
  EXPECT_NEAR(cloud->origin.x(), 500'000.0, 10);
  EXPECT_LE(*std::max_element(cloud->y.begin(), cloud->y.end()), 50.f);
}

TEST(Las, ReadThroughTheScanFileDispatchByExtensionAndStream) {
  const std::string bytes = LasFile(2, 0, Sweeps());
  std::istringstream in(bytes);
  std::vector<std::string> warnings;
  auto cloud = ReadScanStream(in, ScanFormat::kLas, "stdin", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->size(), 7u);
  EXPECT_EQ(ScanFormatOf("scan.LAS").value(), ScanFormat::kLas);
  EXPECT_FALSE(Writable(ScanFormat::kLas));
}

}  // namespace
}  // namespace scanprep::io
