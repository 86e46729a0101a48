// SPDX-License-Identifier: Apache-2.0
// A file's per-point fields that no stage reads (colour, a scanner's scalars) are kept by the PLY
// and PCD readers, value for value in their own types, and written back by both writers, so that
// a cloud read, written and read again has them unchanged (issue 40 item 7: nothing dropped).
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/io/pcd.h"
#include "core/io/ply.h"
#include "core/io/xyz.h"
#include "tests/support/attribute_values.h"

namespace scanprep::io {
namespace {

using ::testing::HasSubstr;
using testing::Values;

// Three vertices, the second without a position; uchar colour, a signed short and a double, and
// a list property no array can hold.
constexpr char kPly[] =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nproperty uchar red\nproperty short offset\nproperty double stamp\n"
    "property list uchar int tags\nend_header\n"
    "0 0 0 255 -300 1e15 2 7 8\n"
    "nan 0 0 1 1 1 0\n"
    "1 0 0 17 32767 0.125 1 9\n";

PointCloud ReadKnownPly(std::vector<std::string>& warnings) {
  std::stringstream in(kPly);
  auto cloud = ReadPly(in, "known.ply", warnings);
  EXPECT_TRUE(cloud.ok()) << cloud.status();
  return cloud.ok() ? *std::move(cloud) : PointCloud{};
}

void ExpectKnownAttributes(const PointCloud& cloud) {
  ASSERT_EQ(cloud.size(), 2u);
  ASSERT_EQ(cloud.attributes.size(), 3u);
  EXPECT_EQ(cloud.attributes[0].name, "red");
  EXPECT_EQ(cloud.attributes[0].type, AttributeType::kUint8);
  EXPECT_EQ(Values(cloud.attributes[0]), (std::vector<double>{255, 17}));  // the NaN row left out
  EXPECT_EQ(cloud.attributes[1].name, "offset");
  EXPECT_EQ(cloud.attributes[1].type, AttributeType::kInt16);
  EXPECT_EQ(Values(cloud.attributes[1]), (std::vector<double>{-300, 32767}));
  EXPECT_EQ(cloud.attributes[2].name, "stamp");
  EXPECT_EQ(cloud.attributes[2].type, AttributeType::kFloat64);
  EXPECT_EQ(Values(cloud.attributes[2]), (std::vector<double>{1e15, 0.125}));
}

TEST(Attributes, PlyKeepsEveryScalarPropertyInItsType) {
  std::vector<std::string> warnings;
  ExpectKnownAttributes(ReadKnownPly(warnings));
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("vertex list properties left out (tags)")));
}

TEST(Attributes, PlyAndPcdWriteThemBack) {
  std::vector<std::string> warnings;
  const PointCloud cloud = ReadKnownPly(warnings);
  std::stringstream ply, pcd;
  ASSERT_TRUE(WritePly(ply, cloud).ok());
  EXPECT_THAT(ply.str(), HasSubstr("property uchar red\nproperty short offset\n"
                                   "property double stamp\nend_header"));
  auto again = ReadPly(ply, "again.ply", warnings);
  ASSERT_TRUE(again.ok()) << again.status();
  ExpectKnownAttributes(*again);
  ASSERT_TRUE(WritePcd(pcd, cloud).ok());
  EXPECT_THAT(pcd.str(), HasSubstr("red offset stamp\nSIZE 4 4 4 1 1 2 8\nTYPE F F F U U I F"));
  auto from_pcd = ReadPcd(pcd, "again.pcd", warnings);
  ASSERT_TRUE(from_pcd.ok()) << from_pcd.status();
  ExpectKnownAttributes(*from_pcd);
}

TEST(Attributes, ANameTheFileGivesItsOwnFieldIsRefused) {
  std::vector<std::string> warnings;
  PointCloud cloud = ReadKnownPly(warnings);
  std::stringstream out;
  ASSERT_TRUE(WritePly(out, cloud).ok());  // control
  cloud.attributes[0].name = "flags";
  const absl::Status status = WritePly(out, cloud);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("attribute 'flags' has the name of another field"));
  cloud.attributes[0].name = "two words";
  EXPECT_THAT(WritePcd(out, cloud).message(), HasSubstr("is not a word"));
}

// PCL's packed colour: a float whose bits are 0xAARRGGBB. Opaque red 0x9F makes it a signalling
// NaN, which a trip through double would quiet (red + 64): the bits are kept, in binary and in
// ASCII (where PCL writes them as an integer), and written back as the same float bits.
TEST(Attributes, PcdPackedColourKeepsItsBits) {
  constexpr uint32_t kColour = 0xFF9F1020u;
  const std::string header =
      "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 1\n"
      "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ";
  std::string binary = header + "binary\n";
  const float xyz[3] = {1, 2, 3};
  binary.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
  binary.append(reinterpret_cast<const char*>(&kColour), 4);
  for (const std::string& file : {binary, header + "ascii\n1 2 3 4288614432\n"}) {
    std::stringstream in(file);
    std::vector<std::string> warnings;
    auto cloud = ReadPcd(in, "colour.pcd", warnings);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    ASSERT_EQ(cloud->attributes.size(), 1u);
    EXPECT_EQ(cloud->attributes[0].type, AttributeType::kFloat32Bits);
    EXPECT_EQ(cloud->attributes[0].Value(0), kColour);
    std::stringstream out;
    ASSERT_TRUE(WritePcd(out, *cloud).ok());
    const std::string written = out.str();
    EXPECT_THAT(written, HasSubstr("FIELDS x y z flags rgb\nSIZE 4 4 4 1 4\nTYPE F F F U F"));
    uint32_t bits = 0;
    std::memcpy(&bits, written.data() + written.size() - 4, 4);  // the record's last field
    EXPECT_EQ(bits, kColour);
  }
}

// Text has no types: a named column gets the narrowest that holds its values; an unnamed one is
// left out with a note, never silently.
TEST(Attributes, XyzKeepsNamedColumnsAndNamesTheOthers) {
  std::vector<std::string> warnings;
  std::stringstream named(
      "# columns: x y z red temperature time\n1 2 3 255 0.5 0.1\nnan 0 0 1 1 1\n"
      "4 5 6 0 -2 123456789.125\n");
  auto cloud = ReadXyz(named, "named.xyz", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  ASSERT_EQ(cloud->attributes.size(), 3u);
  // A column float cannot hold is kept in double, every digit of it.
  EXPECT_EQ(cloud->attributes[2].type, AttributeType::kFloat64);
  EXPECT_EQ(Values(cloud->attributes[2]), (std::vector<double>{0.1, 123456789.125}));
  EXPECT_EQ(cloud->attributes[0].type, AttributeType::kUint8);
  EXPECT_EQ(Values(cloud->attributes[0]), (std::vector<double>{255, 0}));
  EXPECT_EQ(cloud->attributes[1].type, AttributeType::kFloat32);
  EXPECT_EQ(Values(cloud->attributes[1]), (std::vector<double>{0.5, -2}));
  std::stringstream written;
  ASSERT_TRUE(WriteXyz(written, *cloud).ok());
  EXPECT_THAT(written.str(),
              HasSubstr("# columns: x y z flags red temperature time\n1 2 3 0 255 0.5 0.1"));
  std::stringstream unnamed("1 2 3 9 9\n4 5 6 9\n");
  warnings.clear();
  cloud = ReadXyz(unnamed, "unnamed.xyz", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_TRUE(cloud->attributes.empty());
  EXPECT_THAT(warnings,
              ::testing::Contains(HasSubstr("2 column(s) after the 3 read are left out")));
}

}  // namespace
}  // namespace scanprep::io
