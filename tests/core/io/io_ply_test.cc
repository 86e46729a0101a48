// SPDX-License-Identifier: Apache-2.0
// PLY reader/writer: exact round trips, hand-made ASCII and big-endian inputs, malformed inputs,
// and the ten Stanford bunny range scans against the numbers in the data README.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "core/io/ply.h"
#include "tests/support/test_data.h"

namespace scanprep::io {
namespace {

absl::StatusOr<PointCloud> ParseText(const std::string& text,
                                     const std::string& name = "test.ply") {
  std::istringstream in(text);
  std::vector<std::string> ply_warnings;
  return ReadPly(in, name, ply_warnings);
}

std::string ToBytes(const PointCloud& cloud, const WriteOptions& options = {}) {
  std::ostringstream out;
  EXPECT_TRUE(WritePly(out, cloud, options).ok());
  return out.str();
}

// Appends `value` to `bytes` in big-endian order.
template <class T>
void PutBigEndian(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) std::reverse(raw, raw + sizeof(T));
  bytes.append(raw, sizeof(T));
}

PointCloud FullCloud() {
  PointCloud cloud;
  cloud.scans = {ScanMeta{.id = "a"}, ScanMeta{.id = "b"}};
  for (int i = 0; i < 7; ++i) {
    cloud.x.push_back(0.1f * i - 3.3f);
    cloud.y.push_back(1e5f + i);
    cloud.z.push_back(-1e-7f * i);
    const float len = std::sqrt(1.f + i * i);
    cloud.nx.push_back(1.f / len);
    cloud.ny.push_back(i / len);
    cloud.nz.push_back(0.f);
    cloud.scan.push_back(i % 2);
    cloud.scanline.push_back(100000u + i / 3);
    cloud.quality.push_back(i / 7.f);
    cloud.intensity.push_back(1000.f - i);
  }
  cloud.FinishLoading();
  cloud.flags[2] = kRemovedOutlier | kSmoothed;
  cloud.flags[5] = kEdge | kNormalInvalid;
  cloud.flags[6] = kRemovedSimplify;
  return cloud;
}

void ExpectPointEqual(const PointCloud& got, size_t g, const PointCloud& want, size_t w) {
  EXPECT_EQ(got.x[g], want.x[w]);
  EXPECT_EQ(got.y[g], want.y[w]);
  EXPECT_EQ(got.z[g], want.z[w]);
  EXPECT_EQ(got.nx[g], want.nx[w]);
  EXPECT_EQ(got.ny[g], want.ny[w]);
  EXPECT_EQ(got.nz[g], want.nz[w]);
  EXPECT_EQ(got.flags[g], want.flags[w]);
  EXPECT_EQ(got.scan[g], want.scan[w]);
  EXPECT_EQ(got.scanline[g], want.scanline[w]);
  EXPECT_EQ(got.quality[g], want.quality[w]);
  EXPECT_EQ(got.intensity[g], want.intensity[w]);
}

TEST(Ply, BinaryRoundTripKeepsEveryAttributeExactly) {
  const PointCloud cloud = FullCloud();
  absl::StatusOr<PointCloud> all = ParseText(ToBytes(cloud, {.include_removed = true}));
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 7u);
  for (size_t i = 0; i < 7; ++i) ExpectPointEqual(*all, i, cloud, i);
  ASSERT_EQ(all->scans.size(), 2u);
  EXPECT_EQ(all->scans[1].id, "test:1");

  absl::StatusOr<PointCloud> kept = ParseText(ToBytes(cloud));
  ASSERT_TRUE(kept.ok()) << kept.status();
  const std::vector<size_t> kept_index = {0, 1, 3, 4, 5};
  ASSERT_EQ(kept->size(), kept_index.size());
  for (size_t i = 0; i < kept_index.size(); ++i) ExpectPointEqual(*kept, i, cloud, kept_index[i]);
}

TEST(Ply, MinimalCloudRoundTripsThroughAFile) {
  PointCloud cloud;
  cloud.x = {1.5f, -2.f};
  cloud.y = {0.f, 3.25f};
  cloud.z = {7.f, 8.f};
  cloud.scans = {ScanMeta{.id = "x"}};
  cloud.FinishLoading();
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "minimal_scan.ply";
  ASSERT_TRUE(WritePly(path, cloud).ok());
  std::vector<std::string> ply_warnings;
  absl::StatusOr<PointCloud> back = ReadPly(path, ply_warnings);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->x, cloud.x);
  EXPECT_EQ(back->y, cloud.y);
  EXPECT_EQ(back->z, cloud.z);
  EXPECT_FALSE(back->has_normals());
  EXPECT_FALSE(back->has_scanlines());
  EXPECT_TRUE(back->quality.empty());
  EXPECT_TRUE(back->intensity.empty());
  ASSERT_EQ(back->scans.size(), 1u);
  EXPECT_EQ(back->scans[0].id, "minimal_scan");
  std::filesystem::remove(path);
}

TEST(Ply, WriterRejectsInconsistentArrays) {
  PointCloud cloud = FullCloud();
  cloud.quality.pop_back();
  std::ostringstream out;
  const absl::Status status = WritePly(out, cloud);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("cloud.quality has 6 entries for 7 points"), std::string::npos)
      << status;
}

TEST(Ply, AsciiWithMixedTypesExtraPropertiesAndFaces) {
  const std::string text =
      "ply\r\n"
      "format ascii 1.0\r\n"
      "comment made by hand\r\n"
      "obj_info anything goes here\r\n"
      "element vertex 3\r\n"
      "property double x\r\n"
      "property uchar red\r\n"
      "property int y\r\n"
      "property float z\r\n"
      "property float confidence\r\n"
      "property float intensity\r\n"
      "property list uchar int extra_list\r\n"
      "element face 2\r\n"
      "property list uchar int vertex_indices\r\n"
      "end_header\r\n"
      "0.125 255 -4 1e-3 0.5 12 0\r\n"
      "+2.5 0 7 -3.75 1.7 13 2 5 6\r\n"
      "1e2 1 0 0 -0.2 14 1 9\r\n"
      "3 0 1 2\r\n"
      "0\r\n";
  absl::StatusOr<PointCloud> cloud = ParseText(text);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 3u);
  EXPECT_EQ(cloud->x, (std::vector<float>{0.125f, 2.5f, 100.f}));
  EXPECT_EQ(cloud->y, (std::vector<float>{-4.f, 7.f, 0.f}));
  EXPECT_EQ(cloud->z, (std::vector<float>{1e-3f, -3.75f, 0.f}));
  EXPECT_EQ(cloud->quality, (std::vector<float>{0.5f, 1.f, 0.f}));  // clamped to [0,1]
  EXPECT_EQ(cloud->intensity, (std::vector<float>{12.f, 13.f, 14.f}));
  EXPECT_EQ(cloud->scan, (std::vector<uint32_t>{0, 0, 0}));
  EXPECT_EQ(cloud->flags, (std::vector<uint8_t>{0, 0, 0}));
  EXPECT_FALSE(cloud->has_normals());
}

// The per-point metadata names other tools write: scan_id for the scan, scanline_id or row for the
// scanline. A column under a name the reader does not know would be dropped without a word.
TEST(Ply, ScanAndScanlineColumnsUnderTheirCommonNames) {
  for (const char* scanline : {"scanline", "scanline_id", "row"}) {
    SCOPED_TRACE(scanline);
    const std::string text = absl::StrCat(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nproperty uint scan_id\nproperty uint ",
        scanline,
        "\nend_header\n"
        "0 0 0 0 4\n1 0 0 1 5\n2 0 0 1 6\n");
    absl::StatusOr<PointCloud> cloud = ParseText(text);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_EQ(cloud->scan, (std::vector<uint32_t>{0, 1, 1}));
    EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{4, 5, 6}));
  }
}

TEST(Ply, BigEndianDoublesWithListElementBeforeVertices) {
  std::string bytes =
      "ply\nformat binary_big_endian 1.0\n"
      "element face 2\nproperty list uchar int vertex_indices\n"
      "element vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
      "property short scanline\nproperty float nx\nproperty float ny\nproperty float nz\n"
      "end_header\n";
  PutBigEndian<uint8_t>(bytes, 3);
  for (int32_t v : {0, 1, 0}) PutBigEndian(bytes, v);
  PutBigEndian<uint8_t>(bytes, 0);
  const double coords[2][3] = {{0.1, -123456.789, 1e-9}, {2.0 / 3.0, 5.0, -7.5}};
  for (int i = 0; i < 2; ++i) {
    for (double c : coords[i]) PutBigEndian(bytes, c);
    PutBigEndian<int16_t>(bytes, static_cast<int16_t>(40 + i));
    for (float n : {0.f, -1.f, 0.5f}) PutBigEndian(bytes, n);
  }
  absl::StatusOr<PointCloud> cloud = ParseText(bytes);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(cloud->x[i], static_cast<float>(coords[i][0]));
    EXPECT_EQ(cloud->y[i], static_cast<float>(coords[i][1]));
    EXPECT_EQ(cloud->z[i], static_cast<float>(coords[i][2]));
    EXPECT_EQ(cloud->scanline[i], 40u + i);
    EXPECT_EQ(cloud->normal(i), Eigen::Vector3f(0.f, -1.f, 0.5f));
  }
}

TEST(Ply, RangeGridGivesRowsAsScanlines) {
  // 3 columns x 3 rows; vertices sit in cells 1, 2, 3, 7, 8.
  const std::string text =
      "ply\nformat ascii 1.0\nobj_info num_cols 3\nobj_info num_rows 3\n"
      "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "element range_grid 9\nproperty list uchar int vertex_indices\nend_header\n"
      "1 0 0\n2 0 0\n0 1 0\n1 2 0\n2 2 0\n"
      "0\n1 0\n1 1\n1 2\n0\n0\n0\n1 3\n1 4\n";
  absl::StatusOr<PointCloud> cloud = ParseText(text);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 0, 1, 2, 2}));
}

struct BadInput {
  std::string label;
  std::string text;
  std::string message;  // a fragment the error must contain
};

void PrintTo(const BadInput& input, std::ostream* os) { *os << input.label; }

class PlyMalformed : public ::testing::TestWithParam<BadInput> {};

TEST_P(PlyMalformed, FailsWithAPreciseMessage) {
  absl::StatusOr<PointCloud> cloud = ParseText(GetParam().text, "bad.ply");
  ASSERT_FALSE(cloud.ok());
  EXPECT_EQ(cloud.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(cloud.status().message().find(GetParam().message), std::string::npos) << cloud.status();
  EXPECT_EQ(cloud.status().message().rfind("bad.ply", 0), 0u) << cloud.status();
}

const std::string kAscii = "ply\nformat ascii 1.0\n";  // lines 1-2
const std::string kTwoVertices =
    "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
const std::string kGrid =
    "element range_grid 2\nproperty list uchar int vertex_indices\nend_header\n";
const std::string kBody = "end_header\n1 2 3\n";  // end_header on line 7, vertex 0 on line 8

INSTANTIATE_TEST_SUITE_P(
    Cases, PlyMalformed,
    ::testing::Values(
        BadInput{"NotPly", "plx\nformat ascii 1.0\n", "not a PLY file"},
        BadInput{"NoEndHeader", kAscii + "element vertex 0\nproperty float x\n", "no end_header"},
        BadInput{"UnknownFormat", "ply\nformat binary_middle_endian 1.0\nend_header\n",
                 "line 2: unsupported format 'binary_middle_endian'"},
        BadInput{"UnknownType", kAscii + "element vertex 1\nproperty float128 x\nend_header\n",
                 "line 4: unknown property type 'float128'"},
        BadInput{"BadCount", kAscii + "element vertex -3\nend_header\n",
                 "line 3: element count '-3'"},
        BadInput{"MissingZ",
                 kAscii + "element vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
                 "no scalar property 'z'"},
        BadInput{"NoVertexElement", kAscii + "element face 0\nend_header\n", "no 'vertex' element"},
        BadInput{
            "HugeCount",
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n" +
                std::string(900, '\0'),
            "declares 1000000000000 entries but the data section (900 bytes) cannot hold them"},
        BadInput{"TooFewLines", kAscii + kTwoVertices + "end_header\n1.00 2.00 3.00\n",
                 "data ends before vertex 1 of 2"},
        BadInput{"TooManyLines", kAscii + kTwoVertices + kBody + "4 5 6\n7 8 9\n",
                 "line 10: data after the last declared element"},
        BadInput{"Garbage", kAscii + kTwoVertices + kBody + "4 5.0abc 6\n",
                 "line 9: vertex 1: 'y' value '5.0abc' is not a number"},
        BadInput{"ShortLine", kAscii + kTwoVertices + kBody + "4.0 5.0\n",
                 "line 9: vertex 1: too few values (no value for 'z')"},
        BadInput{"LongLine", kAscii + kTwoVertices + "end_header\n1 2 3 4\n4 5 6\n",
                 "line 8: vertex 0: 1 more values than the header declares"},
        BadInput{"CoordinateBeyondFloat", kAscii + kTwoVertices + "end_header\n1 1e300 3\n4 5 6\n",
                 "line 8: vertex 0: 'y' value 1e+300: coordinate beyond the range of a float"},
        BadInput{"NoVertexMeasured", kAscii + kTwoVertices + "end_header\n1 nan 3\ninf 5 6\n",
                 "bad.ply: no points in the file: all 2 have no measurement (a NaN or infinite "
                 "coordinate, or an invalid state); the first is vertex 0"},
        BadInput{"ListTooLong",
                 kAscii + kTwoVertices +
                     "element face 1\nproperty list uchar int vertex_indices\n" + kBody +
                     "4 5 6\n4 0 1\n",
                 "list 'vertex_indices' declares 4 items but the line has only 2 more values"},
        BadInput{"GridWithoutCols", kAscii + kTwoVertices + kGrid + "1 2 3\n4 5 6\n1 0\n1 1\n",
                 "range_grid element without 'obj_info num_cols'"},
        BadInput{"GridMissesVertex",
                 kAscii + "obj_info num_cols 2\n" + kTwoVertices + kGrid + "1 2 3\n4 5 6\n0\n1 1\n",
                 "range_grid lists 1 of the 2 vertices"},
        BadInput{
            "GridOutOfOrder",
            kAscii + "obj_info num_cols 2\n" + kTwoVertices + kGrid + "1 2 3\n4 5 6\n1 1\n1 0\n",
            "must increase with the grid index"},
        BadInput{
            "GridIndexOutOfRange",
            kAscii + "obj_info num_cols 2\n" + kTwoVertices + kGrid + "1 2 3\n4 5 6\n1 0\n1 2\n",
            "line 14: range_grid 1: 'vertex_indices' value 2: vertex index is not a valid vertex"},
        BadInput{"GridSizeDisagrees",
                 kAscii + "obj_info num_cols 2\nobj_info num_rows 2\n" + kTwoVertices + kGrid +
                     "1 2 3\n4 5 6\n1 0\n1 1\n",
                 "range_grid has 2 entries but num_cols*num_rows = 2*2"}),
    [](const ::testing::TestParamInfo<BadInput>& info) { return info.param.label; });

// A stereo camera's organised cloud written as PLY: its holes are NaN vertices. They are left
// out like the PCD reader and the service leave out such points, counted in a warning, and every
// other per-point value stays with its own vertex.
TEST(Ply, NanVerticesAreLeftOutAndCounted) {
  std::istringstream in(
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nproperty float intensity\nproperty uint scanline\nend_header\n"
      "1 2 3 10 0\nnan nan nan 20 0\n4 5 6 30 1\n7 -inf 9 40 1\n");
  std::vector<std::string> warnings;
  absl::StatusOr<PointCloud> cloud = ReadPly(in, "holes.ply", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->x, (std::vector<float>{1, 4}));
  EXPECT_EQ(cloud->z, (std::vector<float>{3, 6}));
  EXPECT_EQ(cloud->intensity, (std::vector<float>{10, 30}));
  EXPECT_EQ(cloud->scanline, (std::vector<uint32_t>{0, 1}));
  EXPECT_EQ(cloud->flags.size(), 2u);
  EXPECT_EQ(cloud->scan.size(), 2u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "holes.ply: 2 of 4 points have no measurement (a NaN or infinite coordinate, or an "
            "invalid state) and were left out; the first is vertex 1");
}

TEST(Ply, MissingFileIsNotFound) {
  std::vector<std::string> ply_warnings;
  absl::StatusOr<PointCloud> cloud =
      ReadPly(std::filesystem::path("/nonexistent/dir/scan.ply"), ply_warnings);
  EXPECT_EQ(cloud.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(cloud.status().message().find("/nonexistent/dir/scan.ply"), std::string::npos);
}

TEST(Ply, TruncatedBinaryIsCaughtBeforeAllocatingOrAtTheByteOffset) {
  const std::string bytes = ToBytes(FullCloud(), {.include_removed = true});
  const size_t body = bytes.size() - (bytes.find("end_header\n") + 11);
  absl::StatusOr<PointCloud> cloud = ParseText(bytes.substr(0, bytes.size() - 3));
  ASSERT_FALSE(cloud.ok());
  const std::string where =
      absl::StrCat("element 'vertex' declares 7 entries but the data section (", body - 3,
                   " bytes) cannot hold them (at least ", body / 7, " bytes each)");
  EXPECT_NE(cloud.status().message().find(where), std::string::npos) << cloud.status();

  // Lists have no fixed size, so a short list is only found while reading it.
  std::string listed =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const size_t header_size = listed.size();
  listed.append(12, '\0');
  listed.push_back(3);
  listed.append(8, '\0');
  cloud = ParseText(listed);
  ASSERT_FALSE(cloud.ok());
  EXPECT_NE(cloud.status().message().find(absl::StrCat(
                "byte ", header_size + 13,
                ": face 0: list 'vertex_indices' declares 3 items but only 8 bytes remain")),
            std::string::npos)
      << cloud.status();
}

TEST(Ply, BinaryWithTrailingBytesIsRejected) {
  absl::StatusOr<PointCloud> cloud = ParseText(ToBytes(FullCloud()) + "xyz");
  ASSERT_FALSE(cloud.ok());
  EXPECT_NE(cloud.status().message().find("3 bytes after the last declared element"),
            std::string::npos)
      << cloud.status();
}

// Every truncation and random byte corruption must come back as a Status, never a crash; a
// truncated binary file can never be mistaken for a complete one.
TEST(Ply, SurvivesTruncationAndCorruption) {
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nobj_info num_cols 2\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uint scan\n"
      "element range_grid 4\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 3; ++i) {
    for (float v : {1.f * i, 2.f, 3.f}) binary.append(reinterpret_cast<const char*>(&v), 4);
    const uint32_t scan = i % 2;
    binary.append(reinterpret_cast<const char*>(&scan), 4);
  }
  for (int32_t cell : {0, -1, 1, 2}) {  // -1: empty cell
    binary.push_back(cell < 0 ? 0 : 1);
    if (cell >= 0) binary.append(reinterpret_cast<const char*>(&cell), 4);
  }
  absl::StatusOr<PointCloud> whole = ParseText(binary);
  ASSERT_TRUE(whole.ok()) << whole.status();
  EXPECT_EQ(whole->scanline, (std::vector<uint32_t>{0, 1, 1}));
  EXPECT_EQ(whole->scans.size(), 2u);
  for (size_t n = 0; n < binary.size(); ++n) EXPECT_FALSE(ParseText(binary.substr(0, n)).ok()) << n;

  const std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty float y\nproperty "
      "float z\n"
      "property float confidence\nelement face 1\nproperty list uchar int "
      "vertex_indices\nend_header\n"
      "1 2 3 0.5\n4 5 6 0.25\n2 0 1\n";
  for (size_t n = 0; n <= ascii.size(); ++n) (void)ParseText(ascii.substr(0, n));

  std::mt19937 rng(1234);
  size_t accepted = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    std::string corrupt = trial % 2 ? binary : ascii;
    for (int k = 0; k < 3; ++k) corrupt[rng() % corrupt.size()] = static_cast<char>(rng());
    accepted += ParseText(corrupt).ok();
  }
  EXPECT_LT(accepted, 4000u);  // corruption in the header must be caught
}

// ---------------------------------------------------------------------------------------------
// Real data: the ten Stanford bunny range scans (README section 1).

struct BunnyScan {
  const char* file;
  size_t points;
  std::array<double, 3> min, max;
};

constexpr BunnyScan kBunny[] = {
    {"bun000.ply", 40256, {-0.09475, 0.035736, -0.058698}, {0.061, 0.18794, 0.058723}},
    {"bun045.ply", 40097, {-0.06325, 0.034209, -0.045165}, {0.084, 0.187639, 0.093523}},
    {"bun090.ply", 30379, {-0.05925, 0.035003, -0.074846}, {0.062, 0.187934, 0.060868}},
    {"bun180.ply", 40251, {-0.0615, 0.034092, -0.033928}, {0.09475, 0.187605, 0.061187}},
    {"bun270.ply", 31701, {-0.06225, 0.034715, -0.011259}, {0.059, 0.187623, 0.094291}},
    {"bun315.ply", 35336, {-0.0735, 0.034122, -0.019493}, {0.0735, 0.186932, 0.100634}},
    {"chin.ply", 37738, {-0.07125, 0.034043, -0.015159}, {0.1035, 0.166427, 0.144818}},
    {"ear_back.ply", 32193, {-0.084, 0.02579, 0.003733}, {0.1065, 0.187506, 0.115116}},
    {"top2.ply", 38298, {-0.0675, 0.038349, -0.0134}, {0.105, 0.166204, 0.128949}},
    {"top3.ply", 36023, {-0.104, 0.035403, -0.018245}, {0.089, 0.147251, 0.123772}},
};

TEST(PlyBunny, AllTenScansMatchTheReadme) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  size_t total = 0;
  for (const BunnyScan& scan : kBunny) {
    SCOPED_TRACE(scan.file);
    std::vector<std::string> ply_warnings;
    absl::StatusOr<PointCloud> cloud =
        ReadPly(data / "stanford_bunny_range_scans" / scan.file, ply_warnings);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    ASSERT_EQ(cloud->size(), scan.points);
    total += cloud->size();
    ASSERT_EQ(cloud->scans.size(), 1u);
    EXPECT_EQ(cloud->scans[0].id, std::filesystem::path(scan.file).stem().string());
    ASSERT_EQ(cloud->scanline.size(), scan.points);
    EXPECT_TRUE(std::is_sorted(cloud->scanline.begin(), cloud->scanline.end()));
    EXPECT_LT(cloud->scanline.back(), 400u);
    const std::vector<float>* axes[3] = {&cloud->x, &cloud->y, &cloud->z};
    for (int a = 0; a < 3; ++a) {
      const auto [lo, hi] = std::minmax_element(axes[a]->begin(), axes[a]->end());
      EXPECT_NEAR(*lo, scan.min[a], 1e-6) << "axis " << a;
      EXPECT_NEAR(*hi, scan.max[a], 1e-6) << "axis " << a;
    }
  }
  EXPECT_EQ(total, 362272u);
}

TEST(PlyBunny, GridRowsAreScanlinesAlongTheStripe) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  std::vector<std::string> ply_warnings;
  absl::StatusOr<PointCloud> cloud =
      ReadPly(data / "stanford_bunny_range_scans" / "bun000.ply", ply_warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  // 214 distinct rows (27..240), counted independently from the file's range_grid with awk.
  const std::set<uint32_t> rows(cloud->scanline.begin(), cloud->scanline.end());
  EXPECT_EQ(rows.size(), 214u);
  EXPECT_EQ(*rows.begin(), 27u);
  EXPECT_EQ(*rows.rbegin(), 240u);
  std::vector<float> step_mm;
  for (size_t i = 1; i < cloud->size(); ++i) {
    if (cloud->scanline[i] == cloud->scanline[i - 1]) {
      step_mm.push_back(1000.f * (cloud->point(i) - cloud->point(i - 1)).norm());
    }
  }
  ASSERT_GT(step_mm.size(), 39000u);
  std::nth_element(step_mm.begin(), step_mm.begin() + step_mm.size() / 2, step_mm.end());
  const float median = step_mm[step_mm.size() / 2];
  EXPECT_NEAR(median, 0.56f, 0.1f);
  RecordProperty("median_row_step_mm", std::to_string(median));
}

}  // namespace
}  // namespace scanprep::io
