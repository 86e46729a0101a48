// SPDX-License-Identifier: Apache-2.0
// The E57 reader against the reference file in ../shared/data and against files written here by
// a small writer that follows the standard independently: pages with CRC-32C, bit-packed
// integers split across packets, poses, spherical points, grids, invalid states.
#include "core/io/e57.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/io/scan_file.h"
#include "tests/support/test_data.h"

namespace scanprep::io {
namespace {

using ::testing::HasSubstr;

// --- A minimal E57 writer -------------------------------------------------------------------

uint32_t Crc32c(const char* data, size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    crc ^= static_cast<uint8_t>(data[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ ((crc & 1) ? 0x82F63B78u : 0);
  }
  return ~crc;
}

template <class T>
void Put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);  // x86: little-endian
}

// A field as the writer stores it: doubles, or integers packed in `bits` bits above `minimum`.
struct Column {
  std::string xml;  // the prototype element
  std::vector<double> doubles;
  std::vector<int64_t> integers;
  int64_t minimum = 0;
  int bits = 0;
  std::string Bytes() const {
    std::string out;
    if (bits == 0) {
      for (double d : doubles) Put(out, d);
      return out;
    }
    uint64_t bit = 0;
    out.assign((integers.size() * bits + 7) / 8, '\0');
    for (int64_t v : integers) {
      const uint64_t raw = static_cast<uint64_t>(v - minimum);
      for (int b = 0; b < bits; ++b, ++bit) {
        if ((raw >> b) & 1) out[bit / 8] |= static_cast<char>(1 << (bit % 8));
      }
    }
    return out;
  }
};

Column Doubles(const std::string& name, std::vector<double> values) {
  return {.xml = absl::StrCat("<", name, " type=\"Float\"/>"), .doubles = std::move(values)};
}
Column Integers(const std::string& name, std::vector<int64_t> values, int64_t lo, int64_t hi,
                const std::string& scaled = "") {
  Column c{.integers = std::move(values), .minimum = lo};
  c.bits = 64 - __builtin_clzll(static_cast<uint64_t>(hi - lo));
  c.xml = absl::StrCat("<", name, " type=\"", scaled.empty() ? "Integer" : "ScaledInteger",
                       "\" minimum=\"", lo, "\" maximum=\"", hi, "\" ", scaled, "/>");
  return c;
}

struct Scan {
  std::string name;
  std::string pose_xml;  // empty = no pose
  std::vector<Column> columns;
  size_t records = 0;
  std::string codecs;  // extra XML inside <codecs>
};

// The logical bytes of one scan's compressed vector: a section header and data packets, each
// stream split in two packets so the reader must join them (mid-record for packed integers).
std::string Section(const Scan& scan, uint64_t packets_physical) {
  std::vector<std::string> streams;
  for (const Column& c : scan.columns) streams.push_back(c.Bytes());
  std::string packets;
  for (int half = 0; half < 2; ++half) {
    std::string body;
    std::vector<uint16_t> lengths;
    for (const std::string& s : streams) {
      const size_t cut = s.size() / 2 + 1;
      const std::string part =
          half == 0 ? s.substr(0, std::min(cut, s.size())) : s.substr(std::min(cut, s.size()));
      lengths.push_back(static_cast<uint16_t>(part.size()));
      body += part;
    }
    std::string packet;
    Put<uint8_t>(packet, 1);
    Put<uint8_t>(packet, 0);
    const size_t size = 6 + 2 * lengths.size() + body.size();
    const size_t padded = (size + 3) / 4 * 4;
    Put<uint16_t>(packet, static_cast<uint16_t>(padded - 1));
    Put<uint16_t>(packet, static_cast<uint16_t>(lengths.size()));
    for (uint16_t l : lengths) Put(packet, l);
    packet += body;
    packet.resize(padded, '\0');
    packets += packet;
  }
  std::string section;
  Put<uint8_t>(section, 1);
  section.append(7, '\0');
  Put<uint64_t>(section, 32 + packets.size());
  // The packets start right after this 32-byte header.
  Put<uint64_t>(section, packets_physical);
  Put<uint64_t>(section, 0);
  return section + packets;
}

uint64_t Physical(uint64_t logical) { return logical / 1020 * 1024 + logical % 1020; }

// The whole file: header, the scans' sections, the XML; paged with CRC-32C.
std::string E57File(const std::vector<Scan>& scans) {
  std::string logical(48, '\0');
  std::string data3d;
  for (const Scan& scan : scans) {
    const uint64_t at = logical.size();
    logical += Section(scan, Physical(at + 32));
    std::string prototype, codecs;
    for (const Column& c : scan.columns) prototype += c.xml;
    absl::StrAppend(&data3d, "<vectorChild type=\"Structure\"><name type=\"String\"><![CDATA[",
                    scan.name, "]]></name>", scan.pose_xml,
                    "<points type=\"CompressedVector\" fileOffset=\"", Physical(at),
                    "\" recordCount=\"", scan.records, "\"><prototype type=\"Structure\">",
                    prototype, "</prototype><codecs type=\"Vector\">", scan.codecs,
                    "</codecs></points></vectorChild>");
  }
  const std::string xml = absl::StrCat(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<e57Root type=\"Structure\" "
      "xmlns=\"http://www.astm.org/COMMIT/E57/2010-e57-v1.0\"><data3D type=\"Vector\">",
      data3d, "</data3D></e57Root>\n");
  const uint64_t xml_at = logical.size();
  logical += xml;
  logical.resize((logical.size() + 1019) / 1020 * 1020, '\0');
  std::string header;
  header += "ASTM-E57";
  Put<uint32_t>(header, 1);
  Put<uint32_t>(header, 0);
  Put<uint64_t>(header, logical.size() / 1020 * 1024);
  Put<uint64_t>(header, Physical(xml_at));
  Put<uint64_t>(header, xml.size());
  Put<uint64_t>(header, 1024);
  logical.replace(0, 48, header);
  std::string file;
  for (size_t at = 0; at < logical.size(); at += 1020) {
    file.append(logical, at, 1020);
    const uint32_t crc = Crc32c(logical.data() + at, 1020);
    for (int b = 3; b >= 0; --b) file.push_back(static_cast<char>(crc >> (8 * b)));
  }
  return file;
}

const char* kQuarterTurnPose =  // 90° about z, then moved by (100, 200, 300)
    "<pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">0.7071067811865476</w>"
    "<x type=\"Float\"/><y type=\"Float\"/><z type=\"Float\">0.7071067811865476</z></rotation>"
    "<translation type=\"Structure\"><x type=\"Float\">100</x><y type=\"Float\">200</y>"
    "<z type=\"Float\">300</z></translation></pose>";

absl::StatusOr<PointCloud> Read(const std::string& bytes, std::vector<std::string>& warnings) {
  return ReadE57Bytes(bytes, "test.e57", warnings);
}

// --- Files written here -----------------------------------------------------------------------

// Two scans: cartesian ScaledIntegers (17 bits, so records straddle bytes and packets) with a
// pose, intensity and an invalid point; spherical doubles without a pose.
TEST(E57, TwoScansCartesianScaledAndSphericalWithPoses) {
  std::vector<int64_t> xs, ys, zs, state;
  std::vector<double> intensity;
  for (int i = 0; i < 1000; ++i) {
    xs.push_back(i * 37 % 100000);
    ys.push_back(i * 91 % 100000);
    zs.push_back(i);
    state.push_back(i == 500 ? 2 : 0);  // no measurement
    intensity.push_back(i * 0.5);
  }
  const std::string scaled = "scale=\"0.001\" offset=\"-10\"";
  Scan posed{
      .name = "front",
      .pose_xml = kQuarterTurnPose,
      .columns = {Integers("cartesianX", xs, 0, 100000, scaled),
                  Integers("cartesianY", ys, 0, 100000, scaled),
                  Integers("cartesianZ", zs, 0, 100000, scaled),
                  Integers("cartesianInvalidState", state, 0, 2), Doubles("intensity", intensity),
                  Integers("colorRed", std::vector<int64_t>(1000, 7), 0, 255)},
      .records = 1000};
  std::vector<double> range, azimuth, elevation, intensity2;
  for (int i = 0; i < 200; ++i) {
    range.push_back(1000 + i);
    azimuth.push_back(i * 0.01);
    elevation.push_back(0.3 - i * 0.001);
    intensity2.push_back(1);
  }
  Scan spherical{
      .name = "side",
      .columns = {Doubles("sphericalRange", range), Doubles("sphericalAzimuth", azimuth),
                  Doubles("sphericalElevation", elevation), Doubles("intensity", intensity2)},
      .records = 200};
  std::vector<std::string> warnings;
  auto cloud = Read(E57File({posed, spherical}), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 999u + 200u);
  ASSERT_EQ(cloud->scans.size(), 2u);
  EXPECT_EQ(cloud->scans[0].id, "front");
  EXPECT_EQ(cloud->scans[1].id, "side");
  ASSERT_TRUE(cloud->scans[0].camera_position.has_value());
  EXPECT_EQ(*cloud->scans[0].camera_position, Eigen::Vector3d(100, 200, 300));
  EXPECT_FALSE(cloud->scans[1].camera_position.has_value());
  // Point i of the first scan: (x, y, z) turned 90° about z is (-y, x, z), then moved.
  for (int i : {0, 1, 499, 501, 999}) {
    const size_t k = i < 500 ? i : i - 1;
    const double x = xs[i] * 0.001 - 10, y = ys[i] * 0.001 - 10, z = zs[i] * 0.001 - 10;
    EXPECT_NEAR(cloud->x[k], -y + 100, 1e-4) << i;
    EXPECT_NEAR(cloud->y[k], x + 200, 1e-4) << i;
    EXPECT_NEAR(cloud->z[k], z + 300, 1e-4) << i;
    EXPECT_FLOAT_EQ(cloud->intensity[k], intensity[i]);
    EXPECT_EQ(cloud->scan[k], 0u);
  }
  for (int i : {0, 77, 199}) {
    const size_t k = 999 + i;
    const double r = range[i], a = azimuth[i], e = elevation[i];
    EXPECT_NEAR(cloud->x[k], r * std::cos(e) * std::cos(a), 1e-3) << i;
    EXPECT_NEAR(cloud->y[k], r * std::cos(e) * std::sin(a), 1e-3) << i;
    EXPECT_NEAR(cloud->z[k], r * std::sin(e), 1e-3) << i;
    EXPECT_EQ(cloud->scan[k], 1u);
  }
  EXPECT_FALSE(cloud->has_scanlines());
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr(
                            "1 of 1200 points have no measurement (a NaN or infinite coordinate, "
                            "or an invalid state) and were left out; the first is record 500 of "
                            "scan 0 'front'")));
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("no pose (scanner origin) for side")));
  // Only the first scan has a colour: it cannot be one array of the file's points.
  EXPECT_THAT(
      warnings,
      ::testing::Contains(HasSubstr("fields left out (not in every scan, of one type): colorRed")));
  EXPECT_TRUE(cloud->attributes.empty());
}

// A field no stage reads is kept, in the type its prototype bounds, for the output (issue 40
// item 7): an 8-bit colour and a double time stamp, for the valid records only.
TEST(E57, OtherFieldsAreKeptForTheOutput) {
  std::vector<double> xs, stamps;
  std::vector<int64_t> red, state;
  for (int i = 0; i < 50; ++i) {
    xs.push_back(i);
    stamps.push_back(1e9 + 0.5 * i);
    red.push_back(5 * i);
    state.push_back(i == 7 ? 1 : 0);
  }
  Scan scan{.name = "coloured",
            .columns = {Doubles("cartesianX", xs), Doubles("cartesianY", xs),
                        Doubles("cartesianZ", xs), Integers("cartesianInvalidState", state, 0, 2),
                        Integers("colorRed", red, 0, 255), Doubles("timeStamp", stamps)},
            .records = 50};
  std::vector<std::string> warnings;
  auto cloud = Read(E57File({scan}), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 49u);
  ASSERT_EQ(cloud->attributes.size(), 2u);
  EXPECT_EQ(cloud->attributes[0].name, "colorRed");
  EXPECT_EQ(cloud->attributes[0].type, AttributeType::kUint8);
  EXPECT_EQ(cloud->attributes[1].name, "timeStamp");
  EXPECT_EQ(cloud->attributes[1].type, AttributeType::kFloat64);
  for (size_t k = 0; k < cloud->size(); ++k) {
    const int i = k < 7 ? static_cast<int>(k) : static_cast<int>(k) + 1;  // record 7 invalid
    EXPECT_EQ(cloud->attributes[0].Value(k), 5 * i) << k;
    EXPECT_EQ(cloud->attributes[1].Value(k), 1e9 + 0.5 * i) << k;
  }
}

// A georeferenced file: two scans posed 5e5 m out (a UTM easting; 5e8 mm), one in doubles and one
// in 0.1 mm ScaledIntegers, each turned by its own quaternion. Float would hold them on a
// 3 cm lattice; origin + local must equal the pose applied in double to within 1e-4 mm.
TEST(E57, PosesFarFromZeroKeepFullPrecision) {
  struct Far {
    Eigen::Quaterniond rotation;
    Eigen::Vector3d translation;
  };
  const Far poses[] = {
      {Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, 3).normalized())),
       Eigen::Vector3d(500'123.456789, 5'400'987.654321, 312.125)},
      {Eigen::Quaterniond(Eigen::AngleAxisd(-2.0, Eigen::Vector3d(0, 0, 1))),
       Eigen::Vector3d(500'123.0, 5'400'987.5, 312.0)}};
  auto pose_xml = [](const Far& f) {
    const Eigen::Quaterniond& q = f.rotation;
    const Eigen::Vector3d& t = f.translation;
    return absl::StrFormat(
        "<pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">%.17g</w>"
        "<x type=\"Float\">%.17g</x><y type=\"Float\">%.17g</y><z type=\"Float\">%.17g</z>"
        "</rotation><translation type=\"Structure\"><x type=\"Float\">%.17g</x>"
        "<y type=\"Float\">%.17g</y><z type=\"Float\">%.17g</z></translation></pose>",
        q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z());
  };
  // A part about 0.4 m across in its scanner's frame, as the file stores it.
  constexpr int kPoints = 500;
  std::vector<double> x, y, z;
  std::vector<int64_t> xi, yi, zi;
  for (int i = 0; i < kPoints; ++i) {
    xi.push_back(i * 7919 % 4000 - 2000);  // 0.1 mm steps: -0.2 .. 0.2 m
    yi.push_back(i * 104729 % 4000 - 2000);
    zi.push_back(i * 31 % 2000);
    x.push_back(xi.back() * 1e-4 + 0.123456789);
    y.push_back(yi.back() * 1e-4 - 0.0987654321);
    z.push_back(zi.back() * 1e-4 + 0.05);
  }
  const std::string scaled = "scale=\"0.0001\" offset=\"0.25\"";
  Scan doubles{
      .name = "doubles",
      .pose_xml = pose_xml(poses[0]),
      .columns = {Doubles("cartesianX", x), Doubles("cartesianY", y), Doubles("cartesianZ", z)},
      .records = kPoints};
  Scan integers{.name = "integers",
                .pose_xml = pose_xml(poses[1]),
                .columns = {Integers("cartesianX", xi, -2000, 2000, scaled),
                            Integers("cartesianY", yi, -2000, 2000, scaled),
                            Integers("cartesianZ", zi, 0, 2000, scaled)},
                .records = kPoints};
  std::vector<std::string> warnings;
  auto cloud = Read(E57File({doubles, integers}), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->size(), 2u * kPoints);
  constexpr double kTolerance = 1e-7;  // metres: 1e-4 mm
  double worst = 0;
  for (int s = 0; s < 2; ++s) {
    for (int i = 0; i < kPoints; ++i) {
      const Eigen::Vector3d in =
          s == 0 ? Eigen::Vector3d(x[i], y[i], z[i])
                 : Eigen::Vector3d(xi[i] * 1e-4 + 0.25, yi[i] * 1e-4 + 0.25, zi[i] * 1e-4 + 0.25);
      const Eigen::Vector3d exact = poses[s].rotation * in + poses[s].translation;
      const size_t k = s * kPoints + i;
      const Eigen::Vector3d read =
          cloud->origin + Eigen::Vector3d(cloud->x[k], cloud->y[k], cloud->z[k]);
      worst = std::max(worst, (read - exact).cwiseAbs().maxCoeff());
      EXPECT_EQ(cloud->scan[k], static_cast<uint32_t>(s));
    }
    ASSERT_TRUE(cloud->scans[s].camera_position.has_value());
    EXPECT_LE((*cloud->scans[s].camera_position + cloud->origin - poses[s].translation)
                  .cwiseAbs()
                  .maxCoeff(),
              kTolerance)
        << s;
  }
  EXPECT_LE(worst, kTolerance);
}

// A grid written column by column (a terrestrial scanner's vertical sweeps): each column is a
// scanline, its points in row order, whatever order the records came in within it.
// Every point of the file without a position (NaN, or its invalid state set): refused as any
// reader refuses a file with no point, the first one's place named.
TEST(E57, NoMeasuredPointIsNoPointInTheFile) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Scan nan_scan{
      .name = "holes",
      .columns = {Doubles("cartesianX", {nan, 1}), Doubles("cartesianY", {0, 2}),
                  Doubles("cartesianZ", {0, 3}), Integers("cartesianInvalidState", {0, 2}, 0, 2)},
      .records = 2};
  std::vector<std::string> warnings;
  EXPECT_EQ(Read(E57File({nan_scan}), warnings).status().message(),
            "test.e57: no points in the file: all 2 have no measurement (a NaN or infinite "
            "coordinate, or an invalid state); the first is record 0 of scan 0 'holes'");
}

TEST(E57, GridColumnsBecomeScanlinesInRowOrder) {
  std::vector<double> x, y, z;
  std::vector<int64_t> rows, cols;
  for (int c = 0; c < 4; ++c) {
    for (int r = 9; r >= 0; --r) {  // rows written bottom-up
      x.push_back(c);
      y.push_back(r);
      z.push_back(0);
      rows.push_back(r);
      cols.push_back(c);
    }
  }
  Scan grid{
      .name = "grid",
      .columns = {Doubles("cartesianX", x), Doubles("cartesianY", y), Doubles("cartesianZ", z),
                  Integers("rowIndex", rows, 0, 9), Integers("columnIndex", cols, 0, 3)},
      .records = x.size()};
  std::vector<std::string> warnings;
  auto cloud = Read(E57File({grid}), warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_TRUE(cloud->has_scanlines());
  ASSERT_EQ(cloud->size(), 40u);
  for (size_t i = 0; i < 40; ++i) {
    EXPECT_EQ(cloud->scanline[i], i / 10) << i;
    EXPECT_EQ(cloud->x[i], static_cast<float>(i / 10)) << i;  // the line is the column
    EXPECT_EQ(cloud->y[i], static_cast<float>(i % 10)) << i;  // in row order
  }
}

TEST(E57, DamagedTruncatedAndHostileFilesAreRefusedByName) {
  const std::vector<double> values(200, 1.0);  // 4.8 kB: the file spans several pages
  Scan scan{.name = "s",
            .columns = {Doubles("cartesianX", values), Doubles("cartesianY", values),
                        Doubles("cartesianZ", values)},
            .records = 200};
  const std::string good = E57File({scan});
  std::vector<std::string> warnings;
  ASSERT_TRUE(Read(good, warnings).ok());  // control

  std::string damaged = good;
  damaged[100] ^= 1;
  auto status = Read(damaged, warnings).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("page 0 (bytes 0..) fails its CRC-32C"));

  status = Read(good.substr(0, good.size() - 1024), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("truncated or not E57"));

  Scan many = scan;
  many.records = 1'000'000'000;  // 24 GB of doubles claimed by a 6-page file
  status = Read(E57File({many}), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("1000000000 records cannot fit"));

  Scan short_data = scan;
  short_data.records = 201;  // one more than the streams hold
  status = Read(E57File({short_data}), warnings).status();
  EXPECT_THAT(status.message(),
              HasSubstr("field cartesianX: 201 records declared, its data holds 200"));

  Scan codec = scan;
  codec.codecs = "<vectorChild type=\"Structure\"/>";
  status = Read(E57File({codec}), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("a codec other than the standard bitPackCodec"));

  Scan no_xyz = scan;
  no_xyz.columns.pop_back();
  status = Read(E57File({no_xyz}), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("neither cartesianX/Y/Z nor sphericalRange"));

  // 8 bits hold 0..255 but the prototype says at most 200: the attribute type (uchar) is chosen
  // from that range, so a record above it is refused, not cast (ply/pcd_fuzzer found the cast).
  Scan out_of_range = scan;
  std::vector<int64_t> red(200, 5);
  red[123] = 250;
  out_of_range.columns.push_back(Integers("colorRed", red, 0, 200));
  status = Read(E57File({out_of_range}), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("field colorRed record 123: 250 is outside its range"));
  red[123] = 200;  // control: the maximum itself is a value
  out_of_range.columns.back() = Integers("colorRed", red, 0, 200);
  EXPECT_TRUE(Read(E57File({out_of_range}), warnings).ok());

  status = Read("ASTM-E58" + good.substr(8), warnings).status();
  EXPECT_THAT(status.message(), HasSubstr("no 'ASTM-E57' signature"));
}

// --- The reference file -----------------------------------------------------------------------

TEST(E57SharedData, BunnyReferenceFile) {
  SCANPREP_REQUIRE_SHARED_DATA(dir);
  std::vector<std::string> warnings;
  auto cloud = ReadScanFile(dir / "e57_bunny_sample" / "bunnyDouble.e57", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  // The data README: one data3D "bunny" of 30,571 records, no pose, no grid, no intensity; its
  // XML's cartesianBounds, which the points must reach exactly.
  ASSERT_EQ(cloud->scans.size(), 1u);
  EXPECT_EQ(cloud->scans[0].id, "bunny");
  EXPECT_FALSE(cloud->scans[0].camera_position.has_value());
  EXPECT_FALSE(cloud->has_scanlines());
  EXPECT_TRUE(cloud->intensity.empty());
  size_t invalid = 0;
  for (const std::string& w : warnings) {
    if (w.find("points without a valid position") != std::string::npos) {
      invalid = std::stoul(w.substr(w.find(": ") + 2));
    }
  }
  EXPECT_EQ(cloud->size() + invalid, 30'571u);
  EXPECT_GT(cloud->size(), 30'000u);
  auto expect_bounds = [](const std::vector<float>& v, double lo, double hi) {
    const auto [min, max] = std::minmax_element(v.begin(), v.end());
    EXPECT_EQ(*min, static_cast<float>(lo));
    EXPECT_EQ(*max, static_cast<float>(hi));
  };
  expect_bounds(cloud->x, -0.094689, 0.061009);
  expect_bounds(cloud->y, 0.040011, 0.187321);
  expect_bounds(cloud->z, -0.061873, 0.058799);
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("no pose (scanner origin) for bunny")));
}

}  // namespace
}  // namespace scanprep::io
