// SPDX-License-Identifier: Apache-2.0
// Extension dispatch of ReadScanFile.
#include <fstream>

#include <gtest/gtest.h>

#include "core/io/scan_file.h"

namespace scanprep::io {
namespace {

absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path) {
  std::vector<std::string> warnings;
  absl::StatusOr<PointCloud> cloud = io::ReadScanFile(path, warnings);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  return cloud;
}

std::filesystem::path WriteTemp(const std::string& name, const std::string& text) {
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(ScanFile, DispatchesOnTheExtension) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n1 2 3\n";
  for (const char* name : {"a.ply", "b.PLY"}) {
    absl::StatusOr<PointCloud> cloud = ReadScanFile(WriteTemp(name, ply));
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_EQ(cloud->point(0), Eigen::Vector3f(1, 2, 3));
  }
  for (const char* name : {"c.xyz", "d.asc", "e.TXT", "f.pts"}) {
    absl::StatusOr<PointCloud> cloud = ReadScanFile(WriteTemp(name, "4 5 6\n7 8 9\n"));
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_EQ(cloud->size(), 2u);
    EXPECT_EQ(cloud->point(1), Eigen::Vector3f(7, 8, 9));
  }
  // A PLY body in a .xyz file is parsed as text, so the format really follows the extension.
  EXPECT_FALSE(ReadScanFile(WriteTemp("g.xyz", ply)).ok());
}

TEST(ScanFile, PcdGoesToThePcdReaderWithItsWarnings) {
  const std::string pcd =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
      "POINTS 1\nDATA ascii\n1 2 3\n";
  for (const char* name : {"g.pcd", "h.PCD"}) {
    std::vector<std::string> warnings;
    absl::StatusOr<PointCloud> cloud = io::ReadScanFile(WriteTemp(name, pcd), warnings);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_EQ(cloud->point(0), Eigen::Vector3f(1, 2, 3));
    ASSERT_EQ(warnings.size(), 1u);  // no VIEWPOINT line
    EXPECT_NE(warnings[0].find("no VIEWPOINT line"), std::string::npos) << warnings[0];
  }
}

TEST(ScanFile, UnknownExtensionIsRejected) {
  const absl::StatusOr<PointCloud> cloud = ReadScanFile(WriteTemp("scene.obj", "whatever"));
  ASSERT_EQ(cloud.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(cloud.status().message().find("unsupported file extension '.obj'"), std::string::npos)
      << cloud.status();
}

}  // namespace
}  // namespace scanprep::io
