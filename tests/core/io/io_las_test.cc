// SPDX-License-Identifier: Apache-2.0
// The LAS reader against files written here from the ASPRS specification's layouts: LAS 1.2
// format 0, LAS 1.4 format 6 (64-bit count, moved flags, wide scan angle), records with extra
// bytes, scanlines from the scan direction and edge flags, LAZ and damaged headers refused. The
// LAS writer against the records' raw bytes: a georeferenced file written back has its own
// integers, a cloud far from zero comes back within half a unit of its scale, and a coordinate
// beyond 32 bits of the grid is refused by name.
#include "core/io/las.h"

#include <algorithm>
#include <array>
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

// Issue 39: a negative scale is read as the header says (mirrored), and said; the same file with
// its positive scale is the control.
TEST(Las, ANegativeScaleIsReadMirroredAndSaid) {
  std::string file = LasFile(2, 0, Sweeps());
  PutAt(file, 131, -0.001);  // the x scale
  std::vector<std::string> warnings;
  auto cloud = Read(file, warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  for (int i = 0; i < 7; ++i)
    EXPECT_NEAR(World(*cloud, 0, i), (1000 * i - 500) * -0.001 + 1000, 1e-6);
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("x scale -0.001 is negative")));
  std::vector<std::string> plain;
  ASSERT_TRUE(Read(LasFile(2, 0, Sweeps()), plain).ok());
  EXPECT_THAT(plain, ::testing::Not(::testing::Contains(HasSubstr("negative"))));
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
    // The formats with colour keep it for the output, from where the spec puts it.
    const bool colour =
        format == 2 || format == 3 || format == 5 || format == 7 || format == 8 || format == 10;
    const bool gps = format != 0 && format != 2;
    ASSERT_EQ(cloud->attributes.size(), (colour ? 3u : 0u) + (gps ? 1u : 0u)) << format;
    for (int channel = 0; colour && channel < 3; ++channel) {
      const PointAttribute& a = cloud->attributes[channel];
      EXPECT_EQ(a.name, (std::array<const char*, 3>{"red", "green", "blue"}[channel]));
      EXPECT_EQ(a.type, AttributeType::kUint16);
      for (size_t i = 0; i < cloud->size(); ++i) {
        EXPECT_EQ(a.Value(i), cloud->intensity[i] + channel + 1) << format << " " << i;
      }
    }
    if (!gps) continue;
    const PointAttribute& time = cloud->attributes.back();
    EXPECT_EQ(time.name, "gps_time");
    EXPECT_EQ(time.type, AttributeType::kFloat64);
    for (size_t i = 0; i < cloud->size(); ++i) {
      EXPECT_EQ(time.Value(i), 1e5 + 0.25 * cloud->intensity[i]) << format << " " << i;
    }
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
// there, the scale is 1 mm. 200 points of format 1 over 50 m.
constexpr double kUtmOffset[3] = {500'000.0, 5'000'000.0, 100.0};
std::vector<LasPoint> UtmPoints() {
  std::vector<LasPoint> points;
  for (int i = 0; i < 200; ++i) {
    points.push_back({.x = 37 * i - 3001,
                      .y = 1 + (i * 7919) % 50'000,
                      .z = -13 * i,
                      .intensity = static_cast<uint16_t>(i * 311)});
  }
  return points;
}
std::string UtmFile(const std::vector<LasPoint>& points) {
  std::string bytes = LasFile(2, 1, points);
  for (int k = 0; k < 3; ++k) PutAt<double>(bytes, 155 + 8 * k, kUtmOffset[k]);
  return bytes;
}

// Every coordinate comes back to half a unit of its scale, so a file written from it has the same
// integers.
TEST(Las, UtmCoordinatesKeepEveryUnitOfTheirScale) {
  const std::vector<LasPoint> points = UtmPoints();
  std::vector<std::string> warnings;
  auto cloud = Read(UtmFile(points), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t integers[3] = {points[i].x, points[i].y, points[i].z};
    for (int k = 0; k < 3; ++k) {
      const double truth = integers[k] * 0.001 + kUtmOffset[k];
      ASSERT_NEAR(World(*cloud, k, i), truth, 0.5e-3) << i << " axis " << k;
      EXPECT_EQ(std::lround((World(*cloud, k, i) - kUtmOffset[k]) / 0.001), integers[k]);
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
  EXPECT_TRUE(Writable(ScanFormat::kLas));
}

template <class T>
T At(const std::string& file, size_t at) {
  T value;
  std::memcpy(&value, file.data() + at, sizeof value);
  return value;
}

// Where point i's record starts, by the header's offset to the points and record length.
size_t Record(const std::string& file, size_t i) {
  return At<uint32_t>(file, 96) + i * At<uint16_t>(file, 105);
}

std::array<int32_t, 3> Integers(const std::string& file, size_t i) {
  const size_t at = Record(file, i);
  return {At<int32_t>(file, at), At<int32_t>(file, at + 4), At<int32_t>(file, at + 8)};
}

absl::StatusOr<std::string> Written(const PointCloud& cloud, const WriteOptions& options = {}) {
  std::ostringstream out;
  if (absl::Status s = WriteScanStream(out, ScanFormat::kLas, cloud, options); !s.ok()) return s;
  return out.str();
}

// The georeferenced file read and written back untouched: the same scale, offset, count and
// integers (what PDAL or LAStools would read back), bounds from the input's integers.
TEST(LasWrite, UtmFileWrittenBackKeepsEveryInteger) {
  const std::vector<LasPoint> points = UtmPoints();
  const std::string input = UtmFile(points);
  std::vector<std::string> warnings;
  auto cloud = Read(input, warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  auto output = Written(*cloud);
  ASSERT_TRUE(output.ok()) << output.status();
  ASSERT_EQ(output->substr(0, 4), "LASF");
  EXPECT_EQ((*output)[24], 1);
  EXPECT_EQ((*output)[25], 2);
  EXPECT_EQ((*output)[104], 1);  // point data format 1, as read: the GPS time is kept
  ASSERT_EQ(At<uint32_t>(*output, 107), points.size());
  ASSERT_EQ(output->size(), Record(*output, points.size()));
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(At<double>(*output, 131 + 8 * k), 0.001) << k;
    EXPECT_EQ(At<double>(*output, 155 + 8 * k), kUtmOffset[k]) << k;
  }
  std::array<int32_t, 3> lo = Integers(input, 0), hi = lo;
  for (size_t i = 0; i < points.size(); ++i) {
    const std::array<int32_t, 3> in = Integers(input, i), out = Integers(*output, i);
    EXPECT_EQ(out, in) << "point " << i;
    EXPECT_EQ(At<uint16_t>(*output, Record(*output, i) + 12), points[i].intensity) << i;
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], in[k]), hi[k] = std::max(hi[k], in[k]);
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(At<double>(*output, 179 + 16 * k), hi[k] * 0.001 + kUtmOffset[k]) << k;
    EXPECT_EQ(At<double>(*output, 187 + 16 * k), lo[k] * 0.001 + kUtmOffset[k]) << k;
  }
}

// A cloud from no LAS (1 µm grid around its origin), 5e5 m east and 5e6 m north in millimetres,
// with scanlines and removed points: read back within half a unit of the grid, the same lines, the
// flags in the user data byte and removed points as noise (class 7) only when asked for.
TEST(LasWrite, FarCloudComesBackWithinHalfAUnitWithItsLinesAndFlags) {
  PointCloud cloud;
  cloud.origin = {5e8, 5e9, 1e5};
  std::vector<uint8_t> flags;
  for (uint32_t i = 0; i < 60; ++i) {
    cloud.x.push_back(0.1234567f * i - 3.f);
    cloud.y.push_back(-7.654321f * i);
    cloud.z.push_back(1e-3f * static_cast<float>(i * i));
    cloud.scanline.push_back(i / 20);
    flags.push_back(i % 9 == 4 ? kRemovedOutlier : kEdge);
  }
  cloud.scans.push_back(ScanMeta{.id = "far"});
  cloud.FinishLoading(flags);
  for (bool include_removed : {false, true}) {
    auto output = Written(cloud, {.include_removed = include_removed});
    ASSERT_TRUE(output.ok()) << output.status();
    std::vector<std::string> warnings;
    auto back = Read(*output, warnings);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_TRUE(back->has_scanlines());
    size_t k = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      if (!include_removed && cloud.removed(i)) continue;
      const float local[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
      for (int axis = 0; axis < 3; ++axis) {
        const double truth = cloud.origin[axis] + local[axis];
        // Half a unit of the grid, plus ReadLas's half float step at 451 mm (2.7e-5).
        EXPECT_NEAR(World(*back, axis, k), truth, 0.5e-3 + 3e-5) << i;
      }
      EXPECT_EQ(back->scanline[k], cloud.scanline[i]) << i;
      const size_t at = Record(*output, k);
      EXPECT_EQ(static_cast<uint8_t>((*output)[at + 17]), cloud.flags[i]) << i;
      EXPECT_EQ((*output)[at + 15], cloud.removed(i) ? 7 : 0) << i;
      ++k;
    }
    EXPECT_EQ(k, back->size());
    EXPECT_EQ(k, include_removed ? 60u : 53u);
  }
}

// Control for the grid: 3 km from an offset of zero is 3e9 steps of 1 µm, beyond a 32-bit
// integer; refused by name, not wrapped. So is an intensity LAS cannot hold.
TEST(LasWrite, ACoordinateBeyondThirtyTwoBitsIsRefusedByName) {
  PointCloud cloud;
  cloud.x = {0, 3e6f}, cloud.y = {0, 0}, cloud.z = {0, 0};
  cloud.FinishLoading();
  auto output = Written(cloud);
  EXPECT_EQ(output.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(output.status().message(),
              HasSubstr("point 1 x = 3000000 is 3000000000 steps of its scale 0.001 from its "
                        "offset 0, beyond a 32-bit integer"));
  cloud.x[1] = 2e6f;  // 2e9 steps: within
  EXPECT_TRUE(Written(cloud).ok());
  cloud.intensity = {1, 0.5f};
  EXPECT_THAT(Written(cloud).status().message(),
              HasSubstr("point 1 intensity 0.5 is not an integer from 0 to 65535"));
}

// Colour and GPS time go where LAS 1.2 puts them: the format follows the attributes the cloud has
// (1 time, 2 colour, 3 both), each read back as written (8-bit colour scaled to 16 bits as the spec
// asks), and what LAS has no place for (a temperature) is named by LasKeeps' complement.
TEST(LasWrite, ColourAndGpsTimeChooseTheFormatAndComeBackAsWritten) {
  PointCloud base;
  for (int i = 0; i < 5; ++i) base.x.push_back(i), base.y.push_back(0), base.z.push_back(0);
  base.FinishLoading();
  const auto attribute = [](const char* name, AttributeType type, double first) {
    PointAttribute a{.name = name, .type = type};
    for (int i = 0; i < 5; ++i) a.Append(first + 10 * i);
    return a;
  };
  const PointAttribute time = attribute("gps_time", AttributeType::kFloat64, 4.0e8 + 0.125);
  const PointAttribute temperature = attribute("temperature", AttributeType::kFloat32, 20.5);
  struct Case {
    std::vector<PointAttribute> attributes;
    int format;
    double colour_scale;
  };
  const std::vector<PointAttribute> rgb16 = {attribute("red", AttributeType::kUint16, 60000),
                                             attribute("green", AttributeType::kUint16, 7),
                                             attribute("blue", AttributeType::kUint16, 300)};
  const std::vector<PointAttribute> rgb8 = {attribute("red", AttributeType::kUint8, 200),
                                            attribute("green", AttributeType::kUint8, 0),
                                            attribute("blue", AttributeType::kUint8, 17)};
  const std::vector<Case> cases = {
      {{temperature}, 0, 1},
      {{time, temperature}, 1, 1},
      {rgb16, 2, 1},
      {{rgb8[0], rgb8[1], rgb8[2], time}, 3, 256},
      {{rgb16[0], rgb16[1]}, 0, 1},  // two channels are no colour
  };
  for (const Case& c : cases) {
    PointCloud cloud = base;
    cloud.attributes = c.attributes;
    auto output = Written(cloud);
    ASSERT_TRUE(output.ok()) << output.status();
    EXPECT_EQ((*output)[104], c.format);
    std::vector<std::string> warnings;
    auto back = Read(*output, warnings);
    ASSERT_TRUE(back.ok()) << back.status();
    std::vector<std::string> kept;
    for (const PointAttribute& a : back->attributes) {
      kept.push_back(a.name);
      auto written = std::find_if(c.attributes.begin(), c.attributes.end(),
                                  [&](const PointAttribute& w) { return w.name == a.name; });
      ASSERT_NE(written, c.attributes.end()) << a.name;
      const double scale = a.name == "gps_time" ? 1 : c.colour_scale;
      for (size_t i = 0; i < 5; ++i) EXPECT_EQ(a.Value(i), written->Value(i) * scale) << a.name;
    }
    EXPECT_EQ(kept, LasKeeps(c.attributes)) << c.format;
    EXPECT_THAT(
        AttributesLeftOut(ScanFormat::kLas, c.attributes),
        ::testing::Contains("temperature").Times(c.attributes.back().name == "temperature"));
  }
  PointCloud too_bright = base;
  too_bright.attributes = rgb16;
  too_bright.attributes[0].ConvertTo(AttributeType::kInt32);  // a 32-bit field is no LAS colour
  too_bright.attributes[0].Set(3, 70000);
  EXPECT_EQ(Written(too_bright).ok(), true);
  EXPECT_TRUE(LasKeeps(too_bright.attributes).empty());
  too_bright.attributes[0] = attribute("red", AttributeType::kInt16, 0);  // 16 bits, signed
  too_bright.attributes[0].Set(3, -1);
  EXPECT_THAT(Written(too_bright).status().message(),
              HasSubstr("point 3 red -1 is not a colour from 0 to 65535"));
}

}  // namespace
}  // namespace scanprep::io
