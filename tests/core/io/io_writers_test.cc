// SPDX-License-Identifier: Apache-2.0
// The PLY, PCD and XYZ writers against their own readers: a cloud with normals, flags (removed
// points among them) and scanlines comes back exactly, the removed points only when asked for;
// the output format follows the extension. Controls: another program's PCD "flags" of another
// type is not taken for ours, and a bad "# columns:" line or flag value is refused by name.
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/io/pcd.h"
#include "core/io/ply.h"
#include "core/io/scan_file.h"
#include "core/io/xyz.h"

namespace scanprep::io {
namespace {

using ::testing::HasSubstr;

// Values no format rounds: coordinates with full float mantissas, unit normals, every flag bit.
PointCloud Sample() {
  PointCloud cloud;
  std::vector<uint8_t> flags;
  for (uint32_t i = 0; i < 50; ++i) {
    cloud.x.push_back(0.1f * i + 1e-7f * i);
    cloud.y.push_back(-3.3333333f + 0.77f * i);
    cloud.z.push_back(12345.678f / (i + 1));
    const float a = 0.1f * i;
    cloud.nx.push_back(std::cos(a));
    cloud.ny.push_back(std::sin(a));
    cloud.nz.push_back(0);
    flags.push_back(static_cast<uint8_t>(i % 7 == 3 ? int{kRemovedOutlier} : (i * 37) % 64 & ~7));
    cloud.scanline.push_back(i / 10);
  }
  cloud.scans.push_back(ScanMeta{.id = "sample"});
  cloud.FinishLoading(flags);
  return cloud;
}

enum class Format { kPly, kPcd, kXyz };

absl::StatusOr<PointCloud> RoundTrip(const PointCloud& cloud, Format format,
                                     const WriteOptions& options) {
  std::stringstream bytes;
  std::vector<std::string> warnings;
  switch (format) {
    case Format::kPly:
      if (auto s = WritePly(bytes, cloud, options); !s.ok()) return s;
      return ReadPly(bytes, "sample.ply", warnings);
    case Format::kPcd:
      if (auto s = WritePcd(bytes, cloud, options); !s.ok()) return s;
      return ReadPcd(bytes, "sample.pcd", warnings);
    case Format::kXyz:
      if (auto s = WriteXyz(bytes, cloud, options); !s.ok()) return s;
      return ReadXyz(bytes, "sample.xyz", warnings);
  }
  return absl::InternalError("format");
}

// Point i of `cloud` for every kept (or every) point, as the writers order them.
std::vector<size_t> WrittenPoints(const PointCloud& cloud, bool include_removed) {
  std::vector<size_t> out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (include_removed || !cloud.removed(i)) out.push_back(i);
  }
  return out;
}

class Writers : public ::testing::TestWithParam<Format> {};

TEST_P(Writers, PointsNormalsFlagsAndScanlinesComeBackExactly) {
  const PointCloud cloud = Sample();
  ASSERT_EQ(cloud.CountKept(), 43u);  // 7 removed: the removed-point cases are exercised
  for (bool include_removed : {true, false}) {
    auto back = RoundTrip(cloud, GetParam(), {.include_removed = include_removed});
    ASSERT_TRUE(back.ok()) << back.status();
    const std::vector<size_t> expected = WrittenPoints(cloud, include_removed);
    ASSERT_EQ(back->size(), expected.size());
    ASSERT_TRUE(back->has_normals());
    ASSERT_TRUE(back->has_scanlines());
    for (size_t k = 0; k < expected.size(); ++k) {
      const size_t i = expected[k];
      EXPECT_EQ(back->x[k], cloud.x[i]) << k;
      EXPECT_EQ(back->y[k], cloud.y[i]) << k;
      EXPECT_EQ(back->z[k], cloud.z[i]) << k;
      EXPECT_EQ(back->nx[k], cloud.nx[i]) << k;
      EXPECT_EQ(back->ny[k], cloud.ny[i]) << k;
      EXPECT_EQ(back->nz[k], cloud.nz[i]) << k;
      EXPECT_EQ(back->flags[k], cloud.flags[i]) << k;
      EXPECT_EQ(back->scanline[k], cloud.scanline[i]) << k;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, Writers,
                         ::testing::Values(Format::kPly, Format::kPcd, Format::kXyz),
                         [](const auto& info) {
                           return std::string(info.param == Format::kPly   ? "Ply"
                                              : info.param == Format::kPcd ? "Pcd"
                                                                           : "Xyz");
                         });

TEST(Writers, TheExtensionChoosesTheFormat) {
  const std::filesystem::path dir = ::testing::TempDir();
  const PointCloud cloud = Sample();
  for (const char* name : {"w.ply", "w.PCD", "w.las", "w.xyz", "w.asc", "w.txt"}) {
    ASSERT_TRUE(WriteScanFile(dir / name, cloud).ok()) << name;
    std::vector<std::string> warnings;
    auto back = ReadScanFile(dir / name, warnings);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->size(), WrittenPoints(cloud, false).size()) << name;
  }
  const absl::Status obj = WriteScanFile(dir / "w.obj", cloud);
  EXPECT_EQ(obj.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(obj.message(), HasSubstr("cannot write '.obj' files"));
  EXPECT_FALSE(std::filesystem::exists(dir / "w.obj"));
  // LAS is written uncompressed: a .laz name would promise what it is not.
  EXPECT_THAT(WriteScanFile(dir / "w.laz", cloud).message(), HasSubstr("cannot write '.laz'"));
}

// A PCD from elsewhere with a float "flags" field: not ours, so not read as flags.
TEST(Writers, AForeignPcdFlagsFieldIsNotTakenForOurs) {
  std::stringstream in(
      "VERSION 0.7\nFIELDS x y z flags\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\n"
      "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n0 0 0 1.5\n1 0 0 2.5\n");
  std::vector<std::string> warnings;
  auto cloud = ReadPcd(in, "foreign.pcd", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->flags, (std::vector<uint8_t>{0, 0}));
  EXPECT_THAT(warnings.front(), HasSubstr("fields left out: flags (F4 x 1)"));
  EXPECT_TRUE(cloud->attributes.empty());  // nor kept under a name the writer gives its own
}

TEST(Writers, XyzColumnsAreReadByNameAndCheckedByValue) {
  std::vector<std::string> warnings;
  std::stringstream reordered("# columns: z y x flags\n3 2 1 8\n6 5 4 0\n");
  auto cloud = ReadXyz(reordered, "r.xyz", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->x, (std::vector<float>{1, 4}));
  EXPECT_EQ(cloud->z, (std::vector<float>{3, 6}));
  EXPECT_EQ(cloud->flags, (std::vector<uint8_t>{8, 0}));
  EXPECT_FALSE(cloud->has_normals());

  std::stringstream partial_normals("# columns: x y z nx ny\n1 2 3 0 1\n");
  EXPECT_EQ(ReadXyz(partial_normals, "p.xyz", warnings).status().message(),
            "p.xyz: line 1: '# columns:' must name x, y and z, and nx, ny, nz all or none");
  std::stringstream big_flag("# columns: x y z flags\n1 2 3 300\n");
  EXPECT_EQ(ReadXyz(big_flag, "f.xyz", warnings).status().message(),
            "f.xyz: line 2: column 4 '300' is not an integer in [0, 255]");
  std::stringstream short_line("# columns: x y z flags\n1 2 3\n");
  EXPECT_EQ(ReadXyz(short_line, "s.xyz", warnings).status().message(),
            "s.xyz: line 2: expected 4 values (# columns:), found 3 value(s)");
  // Without a columns line, extra columns are ignored as before.
  std::stringstream plain("1 2 3 300 abc\n");
  auto ignored = ReadXyz(plain, "plain.xyz", warnings);
  ASSERT_TRUE(ignored.ok()) << ignored.status();
  EXPECT_EQ(ignored->flags, (std::vector<uint8_t>{0}));
}

}  // namespace
}  // namespace scanprep::io
