// SPDX-License-Identifier: Apache-2.0
// Issue 28: the same scan far from its frame's zero (a plant grid, a georeferenced file) is
// processed exactly as near it. Files with double coordinates are read relative to a local origin,
// the stages work on that local frame, and the writers give back origin + local in double.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "core/base/cancel.h"
#include "core/io/scan_file.h"
#include "core/pipeline/pipeline.h"
#include "core/sim/scan_simulator.h"
#include "tests/support/lattice_scan.h"

namespace scanprep {
namespace {

namespace fs = std::filesystem;

Eigen::Vector3d World(const PointCloud& cloud, size_t i) {
  return cloud.origin + cloud.point(i).cast<double>();
}

// The scan placed `offset` mm away along the diagonal, written to a PLY file (double coordinates
// when the offset is not 0), read back and processed; the sensors move with it, as the scan's
// metadata would say.
PointCloud ProcessAt(double offset) {
  PointCloud placed = testing::LatticeBoxScans().cloud;
  placed.origin = Eigen::Vector3d::Constant(offset);
  const fs::path path = fs::path(::testing::TempDir()) / "far_scan.ply";
  EXPECT_TRUE(io::WriteScanFile(path, placed).ok());
  std::vector<std::string> warnings;
  absl::StatusOr<PointCloud> read = io::ReadScanFile(path, warnings);
  EXPECT_TRUE(read.ok()) << read.status();
  PointCloud cloud = std::move(*read);
  cloud.kind = placed.kind;
  cloud.scans = placed.scans;
  for (ScanMeta& meta : cloud.scans) {
    *meta.camera_position += Eigen::Vector3d::Constant(offset) - cloud.origin;
  }
  CancelToken cancel;
  EXPECT_TRUE(RunPipeline(cloud, {}, cancel).ok());
  return cloud;
}

TEST(FarCoordinates, TheSameScanGivesTheSameLocalResultAtAnyOffset) {
  const PointCloud near = ProcessAt(0);
  EXPECT_TRUE(near.origin.isZero(0));  // an ordinary scan keeps its float coordinates
  ASSERT_GT(near.CountKept(), 1000u);
  for (double offset : {1e5, 1e7, 5e8}) {
    SCOPED_TRACE(offset);
    const PointCloud far = ProcessAt(offset);
    ASSERT_EQ(far.size(), near.size());
    size_t differing_flags = 0;
    double worst = 0, worst_normal = 0;
    for (size_t i = 0; i < near.size(); ++i) {
      differing_flags += far.flags[i] != near.flags[i];
      if (near.removed(i)) continue;
      const Eigen::Vector3d local = World(far, i) - Eigen::Vector3d::Constant(offset);
      worst = std::max(worst, (local - World(near, i)).cwiseAbs().maxCoeff());
      worst_normal = std::max(worst_normal, double{(far.normal(i) - near.normal(i)).norm()});
    }
    EXPECT_EQ(differing_flags, 0u);
    EXPECT_LE(worst, 1e-4) << "mm";
    EXPECT_LE(worst_normal, 1e-4);
  }
}

// The result written in each format the CLI writes, and read back, keeps its coordinates far
// from zero: a float file would keep 32 mm at 5e8 mm.
TEST(FarCoordinates, TheWrittenResultKeepsItsCoordinates) {
  const PointCloud far = ProcessAt(5e8);
  for (const char* name : {"far_result.ply", "far_result.pcd", "far_result.xyz"}) {
    SCOPED_TRACE(name);
    const fs::path path = fs::path(::testing::TempDir()) / name;
    ASSERT_TRUE(io::WriteScanFile(path, far).ok());
    std::vector<std::string> warnings;
    absl::StatusOr<PointCloud> back = io::ReadScanFile(path, warnings);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->size(), far.CountKept());
    double worst = 0;
    for (size_t i = 0, k = 0; i < far.size(); ++i) {
      if (far.removed(i)) continue;
      worst = std::max(worst, (World(*back, k++) - World(far, i)).cwiseAbs().maxCoeff());
    }
    EXPECT_LE(worst, 1e-6) << "mm";
  }
}

}  // namespace
}  // namespace scanprep
