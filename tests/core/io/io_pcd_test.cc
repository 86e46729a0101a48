// SPDX-License-Identifier: Apache-2.0
// PCD reader: ascii, binary and binary_compressed files built here from known points, VIEWPOINT
// as the sensor origin, organised clouds with NaN cells, malformed headers and bodies, and PCL's
// own rs1 and table_scene_mug files against the numbers in the data README.
#include <gtest/gtest.h>
#include <lzf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/io/pcd.h"
#include "tests/support/test_data.h"

namespace scanprep::io {
namespace {

// The data README rounds bounding boxes to six significant digits.
constexpr double kReadmeDigits = 1e-6;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

struct Read {
  absl::StatusOr<PointCloud> cloud;
  std::vector<std::string> warnings;
};

Read Parse(const std::string& bytes) {
  Read r;
  std::istringstream in(bytes);
  r.cloud = ReadPcd(in, "test.pcd", r.warnings);
  return r;
}

bool HasWarning(const Read& r, std::string_view text) {
  return std::any_of(r.warnings.begin(), r.warnings.end(),
                     [&](const std::string& w) { return w.find(text) != std::string::npos; });
}

// The known points: x y z, a unit normal, intensity, and an unused rgb and curvature.
struct Point {
  float x, y, z, nx, ny, nz, intensity;
  uint32_t rgb;
  double curvature;
};

std::vector<Point> KnownPoints() {
  std::vector<Point> points;
  for (int i = 0; i < 5; ++i) {
    const float len = std::sqrt(1.f + i * i);
    points.push_back({0.25f * i - 3.f, 1e4f + i, -1e-6f * i, 1.f / len, i / len, 0.f, 100.f - i,
                      0xff0000u + i, 0.5 * i});
  }
  return points;
}

std::string HeaderText(const std::string& data, uint64_t width = 5, uint64_t height = 1,
                       const std::string& viewpoint = "VIEWPOINT 1.5 -2 300 1 0 0 0\n") {
  return absl::StrCat(
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n",
      "FIELDS x y z normal_x normal_y normal_z intensity rgb curvature _\n",
      "SIZE 4 4 4 4 4 4 4 4 8 1\nTYPE F F F F F F F U F U\nCOUNT 1 1 1 1 1 1 1 1 1 3\n", "WIDTH ",
      width, "\nHEIGHT ", height, "\n", viewpoint, "POINTS ", width * height, "\nDATA ", data,
      "\n");
}

template <class T>
void Put(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// One point's fields in header order; `field` < 0 writes the whole record.
void PutField(std::string& bytes, const Point& p, int field) {
  switch (field) {
    case 0:
      Put(bytes, p.x);
      break;
    case 1:
      Put(bytes, p.y);
      break;
    case 2:
      Put(bytes, p.z);
      break;
    case 3:
      Put(bytes, p.nx);
      break;
    case 4:
      Put(bytes, p.ny);
      break;
    case 5:
      Put(bytes, p.nz);
      break;
    case 6:
      Put(bytes, p.intensity);
      break;
    case 7:
      Put(bytes, p.rgb);
      break;
    case 8:
      Put(bytes, p.curvature);
      break;
    case 9:
      bytes.append(3, '\x7f');
      break;  // padding
  }
}

std::string AsciiFile(const std::vector<Point>& points) {
  std::string text = HeaderText("ascii");
  for (const Point& p : points) {
    // %.9g: every float survives the trip through decimal text exactly.
    absl::StrAppendFormat(&text, "%.9g %.9g %.9g %.9g %.9g %.9g %.9g %u %.17g 0 0 0\n", p.x, p.y,
                          p.z, p.nx, p.ny, p.nz, p.intensity, p.rgb, p.curvature);
  }
  return text;
}

std::string BinaryFile(const std::vector<Point>& points) {
  std::string bytes = HeaderText("binary");
  for (const Point& p : points) {
    for (int f = 0; f < 10; ++f) PutField(bytes, p, f);
  }
  return bytes;
}

// PCL's layout: each field's values for all points, then the next field; padding left out.
std::string CompressedFile(const std::vector<Point>& points) {
  std::string soa;
  for (int f = 0; f < 9; ++f) {
    for (const Point& p : points) PutField(soa, p, f);
  }
  std::string packed(soa.size() * 2 + 16, '\0');
  const unsigned size = lzf_compress(soa.data(), soa.size(), packed.data(), packed.size());
  EXPECT_GT(size, 0u);
  std::string bytes = HeaderText("binary_compressed");
  Put(bytes, static_cast<uint32_t>(size));
  Put(bytes, static_cast<uint32_t>(soa.size()));
  bytes.append(packed.data(), size);
  return bytes;
}

void ExpectKnownPoints(const Read& r) {
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  const std::vector<Point> points = KnownPoints();
  const PointCloud& c = *r.cloud;
  ASSERT_EQ(c.size(), points.size());
  ASSERT_TRUE(c.has_normals());
  ASSERT_EQ(c.intensity.size(), points.size());
  EXPECT_FALSE(c.has_scanlines());  // HEIGHT 1: not organised
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    EXPECT_EQ(c.point(i), Eigen::Vector3f(p.x, p.y, p.z)) << i;
    EXPECT_EQ(c.normal(i), Eigen::Vector3f(p.nx, p.ny, p.nz)) << i;
    EXPECT_EQ(c.intensity[i], p.intensity) << i;
  }
  ASSERT_EQ(c.scans.size(), 1u);
  EXPECT_EQ(c.scans[0].id, "test");
  ASSERT_TRUE(c.scans[0].camera_position.has_value());
  EXPECT_EQ(*c.scans[0].camera_position, Eigen::Vector3d(1.5, -2, 300));
  // rgb and curvature are no slot's: kept as attributes of their own types, value for value, and
  // the padding field is no attribute.
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  ASSERT_EQ(c.attributes.size(), 2u);
  EXPECT_EQ(c.attributes[0].name, "rgb");
  EXPECT_EQ(c.attributes[0].type, AttributeType::kUint32);
  EXPECT_EQ(c.attributes[1].name, "curvature");
  EXPECT_EQ(c.attributes[1].type, AttributeType::kFloat64);
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(c.attributes[0].Value(i), points[i].rgb) << i;
    EXPECT_EQ(c.attributes[1].Value(i), points[i].curvature) << i;
  }
}

TEST(Pcd, AsciiRoundTrip) { ExpectKnownPoints(Parse(AsciiFile(KnownPoints()))); }
TEST(Pcd, BinaryRoundTrip) { ExpectKnownPoints(Parse(BinaryFile(KnownPoints()))); }
TEST(Pcd, BinaryCompressedRoundTrip) { ExpectKnownPoints(Parse(CompressedFile(KnownPoints()))); }

TEST(Pcd, Version06HeaderWithoutViewpointOrHeight) {
  const Read r = Parse(
      "VERSION .6\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n"
      "1 2 3\n4 5 6");
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  EXPECT_EQ(r.cloud->point(1), Eigen::Vector3f(4, 5, 6));
  EXPECT_FALSE(r.cloud->scans[0].camera_position.has_value());
  EXPECT_TRUE(HasWarning(r, "no VIEWPOINT line: sensor origin unknown")) << r.warnings.size();
}

TEST(Pcd, PclsDefaultViewpointMeansUnknown) {
  std::string text = AsciiFile(KnownPoints());
  text.replace(text.find("VIEWPOINT 1.5 -2 300 1 0 0 0"), 28, "VIEWPOINT 0 0 0 1 0 0 0");
  const Read r = Parse(text);
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  EXPECT_FALSE(r.cloud->scans[0].camera_position.has_value());
  EXPECT_TRUE(HasWarning(r, "VIEWPOINT is PCL's default 0 0 0 1 0 0 0"));
}

TEST(Pcd, ViewpointWithARotationGivesItsTranslation) {
  // The translation is the origin in the points' frame whatever the orientation says.
  std::string text = AsciiFile(KnownPoints());
  text.replace(text.find("VIEWPOINT 1.5 -2 300 1 0 0 0"), 28, "VIEWPOINT 0 0 0 0 1 0 0");
  const Read r = Parse(text);
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  ASSERT_TRUE(r.cloud->scans[0].camera_position.has_value());
  EXPECT_EQ(*r.cloud->scans[0].camera_position, Eigen::Vector3d(0, 0, 0));
  EXPECT_FALSE(HasWarning(r, "VIEWPOINT"));
}

TEST(Pcd, OrganisedCloudDropsNaNCellsLoudlyAndKeepsRowsAsScanlines) {
  // 3 x 2 grid; cell (row 0, col 1) and (row 1, col 0) are PCL's "no measurement".
  std::vector<Point> points = KnownPoints();
  points.push_back(points[0]);
  points[1].x = points[1].y = points[1].z = kNaN;
  points[3].x = kNaN;
  std::string bytes = HeaderText("binary", 3, 2);
  for (const Point& p : points) {
    for (int f = 0; f < 10; ++f) PutField(bytes, p, f);
  }
  const Read r = Parse(bytes);
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  ASSERT_EQ(r.cloud->size(), 4u);
  EXPECT_EQ(r.cloud->point(1), Eigen::Vector3f(points[2].x, points[2].y, points[2].z));
  EXPECT_EQ(r.cloud->scanline, (std::vector<uint32_t>{0, 0, 1, 1}));
  EXPECT_TRUE(HasWarning(r,
                         "2 of 6 points have no measurement (a NaN or infinite coordinate, or "
                         "an invalid state) and were left out; the first is point 1"));
}

TEST(Pcd, NoValidPointIsAnError) {
  const Read r = Parse("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\nnan nan nan\n");
  ASSERT_FALSE(r.cloud.ok());
  EXPECT_NE(r.cloud.status().message().find("no points in the file: all 1 have no measurement"),
            std::string::npos)
      << r.cloud.status();
}

TEST(Pcd, IntegerCoordinatesAreRead) {
  std::string bytes = "FIELDS x y z\nSIZE 2 1 8\nTYPE I U I\nWIDTH 1\nDATA binary\n";
  Put(bytes, int16_t{-300});
  Put(bytes, uint8_t{200});
  Put(bytes, int64_t{-5});
  const Read r = Parse(bytes);
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  EXPECT_EQ(r.cloud->point(0), Eigen::Vector3f(-300, 200, -5));
}

struct Malformed {
  std::string text;
  std::string message;
};

TEST(Pcd, MalformedFilesNameTheProblem) {
  const std::string fields = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n";
  std::string huge_claim = fields + "WIDTH 100000\nDATA binary_compressed\n";
  Put(huge_claim, uint32_t{4});
  Put(huge_claim, uint32_t{1200000});
  huge_claim += "abcd";
  std::string corrupt = fields + "WIDTH 1\nDATA binary_compressed\n";
  Put(corrupt, uint32_t{4});
  Put(corrupt, uint32_t{12});
  corrupt += "\xff\xff\xff\xff";
  const std::vector<Malformed> cases = {
      {"", "no DATA line"},
      {"VERSION 0.5\n" + fields, "line 1: VERSION '0.5' is not supported"},
      {"FIELDS x y z\nSIZE 4 4\n", "line 2: SIZE has 2 entries but FIELDS names 3"},
      {"FIELDS x y z\nSIZE 4 4 3\n", "line 2: SIZE of 'z' is 3 (expected 1, 2, 4 or 8)"},
      {"FIELDS x y z\nTYPE F F Q\n", "line 2: TYPE of 'z' is 'Q'"},
      {fields + "COUNT 1 0 1\n", "COUNT of 'y' is 0 (expected 1 to 65536)"},
      {fields + "WIDTH -3\n", "line 4: WIDTH '-3' is not one non-negative integer"},
      {fields + "WIDTH 2\nWIDTH 2\n", "line 5: keyword WIDTH appears twice"},
      {fields + "VIEWPOINT 0 0 0 1 0 0\n", "VIEWPOINT has 6 values"},
      {fields + "VIEWPOINT 0 0 nan 1 0 0 0\n", "VIEWPOINT value 3 'nan' is not a finite number"},
      {fields + "COLOUR 3\n", "line 4: unknown header keyword 'COLOUR'"},
      {fields + "WIDTH 2\nHEIGHT 2\nPOINTS 5\nDATA ascii\n",
       "POINTS 5 but WIDTH x HEIGHT = 2 x 2 = 4"},
      {fields + "WIDTH 1\nHEIGHT 4294967296\nDATA ascii\n",
       "HEIGHT 4294967296 exceeds the limit 4294967295"},
      {fields + "WIDTH 1\nDATA lzma\n", "DATA 'lzma' is not ascii, binary or binary_compressed"},
      {"FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       "'z' is TYPE F with SIZE 2"},
      {"FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA ascii\n1 2\n", "no field 'z'"},
      {"FIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 4\n",
       "field 'x' appears twice"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 2 1\nWIDTH 1\nDATA ascii\n1 2 3 4\n",
       "field 'y' has COUNT 2 (expected 1)"},
      {fields + "FIELDS x y z normal_x\n", "keyword FIELDS appears twice"},
      {fields + "WIDTH 1000000\nDATA ascii\n1 2 3\n",
       "POINTS 1000000 but the ascii body (6 bytes) cannot hold"},
      {fields + "WIDTH 2\nDATA ascii\n1 2 3\n\n\n\n\n\n", "data ends before point 1 of POINTS 2"},
      {fields + "WIDTH 1\nDATA ascii\n1 2 3\n4 5 6\n", "line 7: data after the last of POINTS 1"},
      {fields + "WIDTH 1\nDATA ascii\n1 2\n\n\n",
       "line 6: point 0 has 2 values but the fields declare 3"},
      {fields + "WIDTH 1\nDATA ascii\n1 two 3\n", "line 6: field 'y' value 'two' is not a number"},
      {fields + "WIDTH 2\nDATA binary\n" + std::string(23, '\0'), "need more than the 23 bytes"},
      {fields + "WIDTH 1\nDATA binary\n" + std::string(13, '\0'), "need fewer than the 13 bytes"},
      {fields + "WIDTH 1\nDATA binary_compressed\n\x01",
       "has 1 bytes, fewer than its 8-byte size prefix"},
      {huge_claim, "4 LZF bytes cannot expand to the 1200000 declared (at most 88x)"},
      {corrupt, "decompress to 0 bytes, not the 12 declared (corrupt data)"},
  };
  for (const Malformed& c : cases) {
    const Read r = Parse(c.text);
    ASSERT_FALSE(r.cloud.ok()) << c.message;
    EXPECT_EQ(r.cloud.status().code(), absl::StatusCode::kInvalidArgument) << r.cloud.status();
    EXPECT_NE(r.cloud.status().message().find(c.message), std::string::npos)
        << "expected '" << c.message << "' in: " << r.cloud.status();
  }
}

TEST(Pcd, CompressedSizesMustMatchTheBody) {
  std::string bytes = CompressedFile(KnownPoints());
  // PCL pads its files with zeros after the stream; any other trailing byte is not PCL's.
  EXPECT_TRUE(Parse(bytes + std::string(100, '\0')).cloud.ok());
  const Read r = Parse(bytes + "x");
  ASSERT_FALSE(r.cloud.ok());
  EXPECT_NE(r.cloud.status().message().find("not all of the rest zero padding"), std::string::npos)
      << r.cloud.status();
  const Read cut = Parse(bytes.substr(0, bytes.size() - 1));
  ASSERT_FALSE(cut.cloud.ok());
  EXPECT_NE(cut.cloud.status().message().find("compressed bytes but"), std::string::npos)
      << cut.cloud.status();
}

// PCL's rs1.pcd: one laser scan, binary_compressed, sensor-centred, default VIEWPOINT.
TEST(PcdSharedData, Rs1LaserScene) {
  SCANPREP_REQUIRE_SHARED_DATA(dir);
  std::vector<std::string> warnings;
  const absl::StatusOr<PointCloud> cloud = ReadPcd(dir / "pcl_rs1_laser_scene/rs1.pcd", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 289541u);
  const auto [xmin, xmax] = std::minmax_element(cloud->x.begin(), cloud->x.end());
  const auto [zmin, zmax] = std::minmax_element(cloud->z.begin(), cloud->z.end());
  EXPECT_NEAR(*xmin, -0.129081, kReadmeDigits);
  EXPECT_NEAR(*xmax, 0.13715, kReadmeDigits);
  EXPECT_NEAR(*zmin, 0.566415, kReadmeDigits);
  EXPECT_NEAR(*zmax, 0.746148, kReadmeDigits);
  EXPECT_FALSE(cloud->scans[0].camera_position.has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("VIEWPOINT is PCL's default"), std::string::npos) << warnings[0];
}

// PCL's organised 640x480 stereo cloud: 97,920 NaN cells, 20 empty rows, rgba not used.
TEST(PcdSharedData, OrganisedStereoTableScene) {
  SCANPREP_REQUIRE_SHARED_DATA(dir);
  Read r;
  r.cloud =
      ReadPcd(dir / "pcl_table_scene_mug_stereo/table_scene_mug_stereo_textured.pcd", r.warnings);
  ASSERT_TRUE(r.cloud.ok()) << r.cloud.status();
  ASSERT_EQ(r.cloud->size(), 209280u);
  EXPECT_TRUE(HasWarning(r, "97920 of 307200 points have no measurement"));
  ASSERT_EQ(r.cloud->attributes.size(), 1u);  // the colour, for the output
  EXPECT_EQ(r.cloud->attributes[0].name, "rgba");
  EXPECT_EQ(r.cloud->attributes[0].size(), 209280u);
  std::vector<uint32_t> rows = r.cloud->scanline;
  EXPECT_TRUE(std::is_sorted(rows.begin(), rows.end()));
  rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  EXPECT_EQ(rows.size(), 460u);
  EXPECT_LT(rows.back(), 480u);
  const auto [zmin, zmax] = std::minmax_element(r.cloud->z.begin(), r.cloud->z.end());
  EXPECT_NEAR(*zmin, 0.69001, kReadmeDigits);
  EXPECT_NEAR(*zmax, 2.5927, kReadmeDigits);
  ASSERT_TRUE(r.cloud->scans[0].camera_position.has_value());  // VIEWPOINT 0 0 0 0 1 0 0
  EXPECT_EQ(*r.cloud->scans[0].camera_position, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace scanprep::io
