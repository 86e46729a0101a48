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
using ::testing::Not;
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

// Issue 39, finding 3: a client that states the origin but still sends absolute floats far out
// has rounded them before the server sees them (at 1e6 mm floats are 0.0625 mm apart, more than
// u/4 = 0.025 mm). Relative to the origin they look fine; as sent they are a lattice. Refused,
// naming the coordinate as sent. Control: the same client at 1e5 mm (0.0078 mm apart) passes.
TEST(FarCoordinatesService, AbsoluteFloatsSentBesideAnOriginAreRefusedNotProcessedOnTheirLattice) {
  InProcessServer server;
  for (const float far : {1e6f, 1e5f}) {
    SCOPED_TRACE(far);
    v1::JobHeader header = SimpleHeader();
    header.mutable_origin()->set_x(far);
    header.mutable_origin()->set_y(far);
    header.mutable_origin()->set_z(far);
    v1::PointChunk chunk = LineChunk(10);
    for (int i = 0; i < chunk.xyz_size(); ++i) chunk.set_xyz(i, chunk.xyz(i) + far);
    const absl::Status status =
        client::FromGrpc(RawCall(*server.Stub(), {HeaderRequest(header, 10), ChunkRequest(chunk)}));
    if (far < 1e6f) {
      EXPECT_TRUE(status.ok()) << status;
      continue;
    }
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_THAT(status.message(),
                HasSubstr("chunk 0: point 0: its x = 1000000 as sent (job unit, from its scan's "
                          "points_offset) was rounded by float before it arrived, coarser than "
                          "its scan's uncertainty 0.1 mm (floats are 0.0625 mm apart there"));
    const client::CallErrorDetails details = client::DetailsOf(status);
    EXPECT_EQ(details.reason, "INVALID_CHUNK");
    ASSERT_EQ(details.field_violations.size(), 1u);
    EXPECT_EQ(details.field_violations[0].field, "points[0].xyz");
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

// Issue 40, item 2: stray returns far out are left out like NaN points, not fatal to the scan.
// A 40×40 plane of 0.5 mm spacing in one scan (`scans` = 2: its last `second` points are a
// second scan) whose points `strays` lie `far_mm` out along x, where float's spacing is > u/4.
absl::StatusOr<client::ProcessResult> ProcessPlaneWithStrays(const InProcessServer& server,
                                                             const std::vector<size_t>& strays,
                                                             double far_mm, size_t second = 0,
                                                             bool strict = false) {
  PointCloud cloud = NoisyPlaneWithSpikes(40, 0.5f).cloud;
  for (size_t i : strays) cloud.x[i] = static_cast<float>(far_mm);
  v1::JobHeader header = SimpleHeader();
  if (second > 0) {
    cloud.scans.push_back(ScanMeta{.id = "second"});
    for (size_t i = cloud.size() - second; i < cloud.size(); ++i) cloud.scan[i] = 1;
    *header.add_scans() = header.scans(0);
    header.mutable_scans(1)->set_scan_id("second");
  }
  if (strict) header.mutable_options()->add_fail_on(v1::WARNING_CODE_POINTS_INVALID);
  return server.Client().Process(header, cloud);
}

std::string WarningParam(const v1::Report& report, v1::WarningCode code, const std::string& key) {
  for (const v1::Warning& w : report.warning_details()) {
    if (w.code() == code) return w.params().contains(key) ? w.params().at(key) : "(no param)";
  }
  return "(no warning)";
}

TEST(FarCoordinatesService, AStrayPointFloatCannotHoldIsLeftOutAndNamedNotFatal) {
  InProcessServer server;
  auto near = ProcessPlaneWithStrays(server, {}, 0);
  ASSERT_TRUE(near.ok()) << near.status();
  const size_t n = near->report.points_received();
  ASSERT_GT(n, 1600u);
  EXPECT_EQ(near->report.points_invalid(), 0u);  // control: nothing is left out near the origin

  // 1e8 mm: floats are 8 mm apart there, u = 0.1 mm.
  auto stray = ProcessPlaneWithStrays(server, {700, 5}, 1e8);
  ASSERT_TRUE(stray.ok()) << stray.status();
  EXPECT_EQ(stray->report.points_invalid(), 2u);
  EXPECT_EQ(stray->report.points_processed(), n - 2);
  const v1::Report& r = stray->report;
  EXPECT_EQ(WarningParam(r, v1::WARNING_CODE_POINTS_INVALID, "points_unrepresentable"), "2");
  EXPECT_EQ(WarningParam(r, v1::WARNING_CODE_POINTS_INVALID, "first_invalid_points"), "5,700");
  for (size_t i = 0; i < stray->cloud.size(); ++i) {
    EXPECT_LT(std::abs(stray->cloud.x[i]), 100.f) << "a stray came back, point " << i;
  }

  // Strict fails on it, naming the numbers.
  auto strict = ProcessPlaneWithStrays(server, {700}, 1e8, 0, /*strict=*/true);
  EXPECT_EQ(strict.status().code(), absl::StatusCode::kFailedPrecondition) << strict.status();
  EXPECT_THAT(strict.status().message(), HasSubstr("1 too far from header.origin"));
}

// More than 1 % unrepresentable is a wrong origin: refused while uploading, with the hint; a
// scan over the share inside a job under it is refused at the end, naming the scan.
TEST(FarCoordinatesService, MoreThanOnePercentFarOutIsRefusedWithTheOriginHint) {
  InProcessServer server;
  std::vector<size_t> many;
  for (size_t i = 0; i < 40; ++i) many.push_back(40 * i);  // 2.5 % of the points
  auto wrong_origin = ProcessPlaneWithStrays(server, many, 1e8);
  EXPECT_EQ(wrong_origin.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(wrong_origin.status().message(),
              HasSubstr("more than 1 %: set header.origin near the data"));
  EXPECT_EQ(client::DetailsOf(wrong_origin.status()).reason, "INVALID_CHUNK");

  // 4 of the second scan's 200 points (2 %), 4 of the job's ~1,600 (0.25 %).
  std::vector<size_t> in_second;
  for (size_t i = 0; i < 4; ++i) in_second.push_back(1400 + 10 * i);
  auto scan_over = ProcessPlaneWithStrays(server, in_second, 1e8, 300);
  ASSERT_EQ(scan_over.status().code(), absl::StatusCode::kInvalidArgument) << scan_over.status();
  EXPECT_THAT(scan_over.status().message(),
              HasSubstr("scan 1 (second): 4 of its 300 points are invalid, 4 of them too far"));
  const client::CallErrorDetails details = client::DetailsOf(scan_over.status());
  ASSERT_EQ(details.field_violations.size(), 1u);
  EXPECT_EQ(details.field_violations[0].field, "header.scans[1]");

  // A scan that keeps no valid point (all NaN) is refused too, without the origin hint.
  const size_t size = NoisyPlaneWithSpikes(40, 0.5f).cloud.size();
  std::vector<size_t> second_all;
  for (size_t i = size - 300; i < size; ++i) second_all.push_back(i);
  auto none_kept = ProcessPlaneWithStrays(server, second_all, std::nan(""), 300);
  ASSERT_EQ(none_kept.status().code(), absl::StatusCode::kInvalidArgument) << none_kept.status();
  EXPECT_THAT(none_kept.status().message(),
              HasSubstr("scan 1 (second): 300 of its 300 points are invalid, 0 of them too far"));
  EXPECT_THAT(none_kept.status().message(), Not(HasSubstr("header.origin near")));

  // Control: the same four strays in the first scan are under its share and left out.
  auto scan_under = ProcessPlaneWithStrays(server, {0, 10, 20, 30}, 1e8, 300);
  ASSERT_TRUE(scan_under.ok()) << scan_under.status();
  EXPECT_EQ(scan_under->report.points_invalid(), 4u);
}

}  // namespace
}  // namespace scanprep::testing
