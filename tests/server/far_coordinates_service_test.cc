// SPDX-License-Identifier: Apache-2.0
// Issue 28 through the client and the service: a scan read from a file far from zero is sent
// relative to its points_offset, processed around the job's origin and comes back in the caller's
// coordinates; a client that sends far coordinates without an origin gets a precise error instead
// of a result collapsed onto float's lattice.
#include <cmath>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/call_error.h"
#include "client/cli_args.h"
#include "client/job_builder.h"
#include "core/io/scan_file.h"
#include "core/sim/scan_simulator.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/lattice_scan.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// The scan `offset` mm away along the diagonal, as a PLY file, through `scanprep process`'s job
// builder (its scan metadata as a job file would give it, absolute) and the service.
client::ProcessResult ProcessAt(const InProcessServer& server, double offset,
                                v1::JobHeader* sent = nullptr) {
  const sim::SimulatedCloud scan = LatticeBoxScans();
  PointCloud placed = scan.cloud;
  placed.origin = Eigen::Vector3d::Constant(offset);
  const fs::path path = fs::path(::testing::TempDir()) / "far_part.ply";
  EXPECT_TRUE(io::WriteScanFile(path, placed).ok());
  auto args =
      client::ParseArgs({path.string(), "--unit", "mm", "--include_removed"}, client::JobFlags());
  EXPECT_TRUE(args.ok()) << args.status();
  absl::StatusOr<client::Job> job = client::BuildJob(*args);
  EXPECT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->header.scans_size(), 2);
  for (int s = 0; s < job->header.scans_size(); ++s) {
    v1::ScanHeader& header = *job->header.mutable_scans(s);
    v1::ScanHeader meta = client::ScanHeaderFromMeta(scan.cloud.scans[s]);
    meta.mutable_camera_position()->set_x(meta.camera_position().x() + offset);
    meta.mutable_camera_position()->set_y(meta.camera_position().y() + offset);
    meta.mutable_camera_position()->set_z(meta.camera_position().z() + offset);
    meta.clear_scan_id();
    header.MergeFrom(meta);
  }
  job->header.set_scanner_kind(v1::SCANNER_KIND_LINE);
  if (sent != nullptr) *sent = job->header;
  auto result = server.Client().Process(job->header, job->points);
  EXPECT_TRUE(result.ok()) << result.status();
  return std::move(*result);
}

Eigen::Vector3d World(const PointCloud& cloud, size_t i) {
  return cloud.origin + cloud.point(i).cast<double>();
}

TEST(FarCoordinatesService, TheSameScanGivesTheSameLocalResultAtAnyOffset) {
  InProcessServer server;
  v1::JobHeader sent;
  const client::ProcessResult near = ProcessAt(server, 0, &sent);
  // An ordinary job's wire is what it was before origins existed.
  EXPECT_FALSE(sent.has_origin());
  EXPECT_FALSE(sent.scans(0).has_points_offset());
  ASSERT_GT(near.report.points_returned(), 1000u);
  for (double offset : {1e5, 1e7, 5e8}) {
    SCOPED_TRACE(offset);
    const client::ProcessResult far = ProcessAt(server, offset, &sent);
    EXPECT_TRUE(sent.has_origin());
    ASSERT_EQ(far.cloud.size(), near.cloud.size());
    size_t differing_flags = 0;
    double worst = 0;
    for (size_t i = 0; i < near.cloud.size(); ++i) {
      differing_flags += far.cloud.flags[i] != near.cloud.flags[i];
      if (near.cloud.removed(i)) continue;
      const Eigen::Vector3d local = World(far.cloud, i) - Eigen::Vector3d::Constant(offset);
      worst = std::max(worst, (local - World(near.cloud, i)).cwiseAbs().maxCoeff());
    }
    EXPECT_EQ(differing_flags, 0u);
    EXPECT_LE(worst, 1e-4) << "mm";
  }
}

// A client without origins (any client before them) that sends a scan 1e7 mm out: float's
// lattice is 1 mm there. Refused, naming the chunk and the point, not processed on the lattice.
TEST(FarCoordinatesService, FarCoordinatesWithoutAnOriginAreRefusedNotCollapsed) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader();
  v1::PointChunk chunk = LineChunk(10);
  for (int i = 0; i < chunk.xyz_size(); ++i) chunk.set_xyz(i, chunk.xyz(i) + 1e7f);
  const absl::Status status =
      client::FromGrpc(RawCall(*server.Stub(), {HeaderRequest(header, 10), ChunkRequest(chunk)}));
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  EXPECT_THAT(status.message(),
              HasSubstr("chunk 0: point 0: its x = 10000000 mm from header.origin cannot be held "
                        "as a float to its scan's uncertainty 0.1 mm (floats are 1 mm apart"));
  const client::CallErrorDetails details = client::DetailsOf(status);
  EXPECT_EQ(details.reason, "INVALID_CHUNK");
  ASSERT_EQ(details.field_violations.size(), 1u);
  EXPECT_EQ(details.field_violations[0].field, "points[0].xyz");

  // The same points with the origin stated: accepted, and back in the caller's frame.
  header.mutable_origin()->set_x(1e7);
  header.mutable_origin()->set_y(1e7);
  header.mutable_origin()->set_z(1e7);
  header.mutable_scans(0)->mutable_points_offset()->set_x(1e7);
  header.mutable_scans(0)->mutable_points_offset()->set_y(1e7);
  header.mutable_scans(0)->mutable_points_offset()->set_z(1e7);
  PointCloud line;
  for (int i = 0; i < 10; ++i) line.x.push_back(0.5f * i), line.y.push_back(0), line.z.push_back(0);
  line.FinishLoading();
  auto result = server.Client().Process(header, line);
  ASSERT_TRUE(result.ok()) << result.status();
  for (size_t i = 0; i < result->cloud.size(); ++i) {
    EXPECT_EQ(result->cloud.origin.x(), 1e7);
    EXPECT_EQ(result->cloud.flags[i] & kRemovedMask, 0);
  }
}

// The limit itself (issue 43): a coordinate 300,000 mm from the origin, where floats are
// s = 2^-5 mm apart, sent with uncertainties that put s at u/8, just under u/4, just over u/4 and
// at u/2. The first two are accepted, the last two refused naming the chunk's field and the
// spacing. Controls on both sides, where the limit does not bite: s = u/32 is accepted and s = 2u
// refused by any limit between u/32 and u.
TEST(FarCoordinatesService, ACoordinateIsRefusedExactlyWhereItsFloatSpacingExceedsAQuarterOfU) {
  InProcessServer server;
  constexpr double kX = 300000;
  constexpr double kSpacing = 0.03125;  // 2^-5: floats in [2^18, 2^19) mm
  ASSERT_EQ(std::nextafter(static_cast<float>(kX), 1e9f) - static_cast<float>(kX), kSpacing);
  constexpr double kEpsilon = 1e-6;
  const struct {
    const char* what;
    double uncertainty;
    bool accepted;
  } cases[] = {
      {"s = u/32 (control)", 32 * kSpacing, true},
      {"s = u/8", 8 * kSpacing, true},
      {"s = u/4 - eps", 4 * kSpacing / (1 - kEpsilon), true},
      {"s = u/4 + eps", 4 * kSpacing / (1 + kEpsilon), false},
      {"s = u/2", 2 * kSpacing, false},
      {"s = 2u (control)", kSpacing / 2, false},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    v1::JobHeader header = SimpleHeader();
    header.mutable_scans(0)->set_uncertainty(c.uncertainty);
    v1::PointChunk chunk = LineChunk(10);
    for (int i = 0; i < chunk.xyz_size(); i += 3) chunk.set_xyz(i, chunk.xyz(i) + kX);
    const absl::Status status =
        client::FromGrpc(RawCall(*server.Stub(), {HeaderRequest(header, 10), ChunkRequest(chunk)}));
    if (c.accepted) {
      EXPECT_TRUE(status.ok()) << status;
      continue;
    }
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_THAT(status.message(),
                HasSubstr("chunk 0: point 0: its x = 300000 mm from header.origin cannot be held "
                          "as a float"));
    EXPECT_THAT(status.message(), HasSubstr("(floats are 0.03125 mm apart there, more than u/4)"));
    const client::CallErrorDetails details = client::DetailsOf(status);
    EXPECT_EQ(details.reason, "INVALID_CHUNK");
    ASSERT_EQ(details.field_violations.size(), 1u);
    EXPECT_EQ(details.field_violations[0].field, "points[0].xyz");
  }
}

}  // namespace
}  // namespace scanprep::testing
