// SPDX-License-Identifier: Apache-2.0
// One rule for points without a position and for files without points, whatever the format:
// a "nan nan nan" row (a scanner's "no return") is left out and counted in a warning naming the
// first one's place in the file's own terms, and a file with no point is refused naming the file.
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/io/scan_file.h"
#include "tests/support/las_file.h"

namespace scanprep::io {
namespace {

using ::testing::ElementsAre;

std::filesystem::path WriteTemp(const std::string& name, const std::string& bytes) {
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string Ply(int vertices, const std::string& body) {
  return "ply\nformat ascii 1.0\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n" + body;
}

std::string Pcd(int points, const std::string& body) {
  const std::string n = std::to_string(points);
  return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + n +
         "\nHEIGHT 1\nVIEWPOINT 1 2 3 1 0 0 0\nPOINTS " + n + "\nDATA ascii\n" + body;
}

constexpr char kWhy[] =
    "1 of 3 points have no measurement (a NaN or infinite coordinate, or an invalid state) and "
    "were left out; the first is ";

// The middle row of three is "nan nan nan": text, PLY and PCD alike keep the other two and say
// so once, the place in each file's own terms (a text line, a vertex index, a point index).
TEST(Unmeasured, ANanRowIsLeftOutAndCountedInEveryFormat) {
  const std::string rows = "1 2 3\nnan nan nan\n4 5 6\n";
  struct Case {
    std::string file, bytes, first;
  };
  for (const Case& c :
       {Case{"rows.xyz", rows, "line 2"}, Case{"rows.ply", Ply(3, rows), "vertex 1"},
        Case{"rows.pcd", Pcd(3, rows), "point 1"},
        Case{"inf.xyz", "1 2 3\n4 5 6\n7 -inf 9\n", "line 3"}}) {
    const std::filesystem::path path = WriteTemp(c.file, c.bytes);
    std::vector<std::string> warnings;
    absl::StatusOr<PointCloud> cloud = ReadScanFile(path, warnings);
    ASSERT_TRUE(cloud.ok()) << c.file << ": " << cloud.status();
    ASSERT_EQ(cloud->size(), 2u) << c.file;
    EXPECT_EQ(cloud->point(0), Eigen::Vector3f(1, 2, 3)) << c.file;
    EXPECT_THAT(warnings, ElementsAre(path.string() + ": " + kWhy + c.first)) << c.file;
    // Kept with the scan, for its invalid share in the health report.
    ASSERT_EQ(cloud->scans.size(), 1u) << c.file;
    EXPECT_EQ(cloud->scans[0].points_invalid, 1u) << c.file;
  }
}

TEST(Unmeasured, AFileWithNoPointFailsTheSameWayInEveryFormat) {
  for (const auto& [file, bytes] : std::vector<std::pair<std::string, std::string>>{
           {"empty.xyz", ""},
           {"comments.xyz", "# columns: x y z\n\n# nothing measured\n"},
           {"empty.ply", Ply(0, "")},
           {"empty.pcd", Pcd(0, "")},
           {"empty.las", testing::LasFile(2, 0, {})}}) {
    const std::filesystem::path path = WriteTemp(file, bytes);
    std::vector<std::string> warnings;
    absl::StatusOr<PointCloud> cloud = ReadScanFile(path, warnings);
    EXPECT_EQ(cloud.status().code(), absl::StatusCode::kInvalidArgument) << file;
    EXPECT_EQ(cloud.status().message(), path.string() + ": no points in the file") << file;
  }
  // Every row unmeasured: the same refusal, saying why.
  const std::filesystem::path path = WriteTemp("holes.xyz", "nan nan nan\n1 inf 2\n");
  std::vector<std::string> warnings;
  EXPECT_EQ(ReadScanFile(path, warnings).status().message(),
            path.string() +
                ": no points in the file: all 2 have no measurement (a NaN or infinite "
                "coordinate, or an invalid state); the first is line 1");
}

}  // namespace
}  // namespace scanprep::io
