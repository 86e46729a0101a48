// SPDX-License-Identifier: Apache-2.0
// The request-to-job translation without gRPC: units, poses applied to points and scanner
// metadata, defaults, invalid coordinates, and the end message's count and checksum.
#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_format.h"
#include "server/job/job_assembler.h"

namespace scanprep::server {
namespace {

v1::ProcessRequest Header(const v1::JobHeader& h) {
  v1::ProcessRequest r;
  *r.mutable_header() = h;
  return r;
}

// The end message for `chunks`, as a client computes it.
v1::ProcessRequest End(std::initializer_list<v1::ProcessRequest> chunks) {
  StreamChecksum checksum;
  for (const v1::ProcessRequest& chunk : chunks) checksum.Add(chunk.points());
  v1::ProcessRequest r;
  *r.mutable_end() = checksum.End();
  return r;
}

// Scan in inches, rotated 90° about z, shifted by (1, 0, 0) in.
v1::JobHeader InchHeader() {
  v1::JobHeader h;
  h.set_unit(v1::LENGTH_UNIT_INCH);
  v1::ScanHeader* scan = h.add_scans();
  v1::RigidTransform* t = scan->mutable_to_common();
  t->mutable_rotation()->set_z(std::sqrt(0.5));
  t->mutable_rotation()->set_w(std::sqrt(0.5));
  t->mutable_translation()->set_x(1);
  scan->mutable_camera_position()->set_x(2);
  scan->mutable_view_direction()->set_x(3);  // not unit: normalised by the server
  scan->mutable_projector_direction()->set_y(1);
  scan->set_scanline_spacing(0.01);
  return h;
}

TEST(JobAssembler, AppliesUnitAndPoseToPointsAndScannerMetadata) {
  JobAssembler assembler(JobLimits{});
  v1::JobHeader h = InchHeader();
  h.set_total_points(3);
  ASSERT_TRUE(assembler.Add(Header(h)).ok());
  v1::ProcessRequest chunk;
  for (float v : {1.f, 0.f, 0.f, 0.f, 1.f, std::numeric_limits<float>::infinity(), 0.f, 0.f, 2.f}) {
    chunk.mutable_points()->add_xyz(v);
  }
  ASSERT_TRUE(assembler.Add(chunk).ok());
  ASSERT_TRUE(assembler.Add(End({chunk})).ok());
  auto job = assembler.Finish();
  ASSERT_TRUE(job.ok()) << job.status();

  EXPECT_EQ(job->mm_per_unit, 25.4);
  EXPECT_EQ(job->points_received, 3u);
  EXPECT_EQ(job->points_invalid, 1u);
  EXPECT_EQ(job->cloud.scans[0].points_invalid, 1u);  // the scan's invalid share in health
  ASSERT_EQ(job->warnings.size(), 1u);
  EXPECT_EQ(job->warnings[0].code, WarningCode::kPointsInvalid);
  const PointCloud& c = job->cloud;
  ASSERT_EQ(c.size(), 2u);
  // (1,0,0) in → rotated (0,1,0) + (1,0,0) → (25.4, 25.4, 0) mm.
  EXPECT_NEAR(c.x[0], 25.4, 1e-4);
  EXPECT_NEAR(c.y[0], 25.4, 1e-4);
  EXPECT_NEAR(c.z[1], 50.8, 1e-4);
  EXPECT_EQ(c.flags.size(), 2u);

  ASSERT_EQ(c.scans.size(), 1u);
  const ScanMeta& scan = c.scans[0];
  EXPECT_EQ(scan.id, "scan0");
  ASSERT_TRUE(scan.camera_position.has_value());
  EXPECT_TRUE(scan.camera_position->isApprox(Eigen::Vector3d(25.4, 50.8, 0), 1e-9));
  ASSERT_TRUE(scan.view_direction.has_value());
  EXPECT_TRUE(scan.view_direction->isApprox(Eigen::Vector3d(0, 1, 0), 1e-9));
  EXPECT_TRUE(scan.projector_direction->isApprox(Eigen::Vector3d(-1, 0, 0), 1e-9));
  EXPECT_FALSE(scan.projector_position.has_value());
  EXPECT_NEAR(scan.scanline_spacing, 0.254, 1e-12);
  EXPECT_EQ(scan.uncertainty, 0.1);  // 0 = the 0.1 mm default, not 0.1 in
  EXPECT_EQ(c.kind, ScannerKind::kLine);
}

// What admission reserves for an upload (PeakBytesWith, before each message) covers what the
// arrays then take: the bytes announced before the last chunk, and those for no more points once
// every point arrived (no growth to hide an undercount behind), are at least the finished
// cloud's array storage and flags.
TEST(JobAssembler, TheBytesAnnouncedForTheNextChunkCoverTheArraysItGrows) {
  constexpr int kChunks = 5, kPoints = 1'000;
  JobAssembler assembler(JobLimits{});
  v1::JobHeader h = InchHeader();
  h.set_total_points(kChunks * kPoints);
  ASSERT_TRUE(assembler.Add(Header(h)).ok());
  StreamChecksum checksum;
  uint64_t announced = 0;
  for (int c = 0; c < kChunks; ++c) {
    v1::ProcessRequest chunk;
    for (int i = 0; i < kPoints; ++i) {
      for (float v : {0.01f * i, 0.01f * c, 0.f}) chunk.mutable_points()->add_xyz(v);
      chunk.mutable_points()->add_scanline(c);
    }
    announced = assembler.PeakBytesWith(kPoints);
    ASSERT_TRUE(assembler.Add(chunk).ok());
    checksum.Add(chunk.points());
  }
  const uint64_t holds = assembler.PeakBytesWith(0);
  v1::ProcessRequest end;
  *end.mutable_end() = checksum.End();
  ASSERT_TRUE(assembler.Add(end).ok());
  auto job = assembler.Finish();
  ASSERT_TRUE(job.ok()) << job.status();
  const PointCloud& cloud = job->cloud;
  const uint64_t held =
      sizeof(float) * (cloud.x.capacity() + cloud.y.capacity() + cloud.z.capacity() +
                       cloud.scan.capacity() + cloud.scanline.capacity()) +
      cloud.flags.capacity();
  EXPECT_GE(announced, held);
  EXPECT_GE(holds, held);
  EXPECT_EQ(cloud.scanline.size(), static_cast<size_t>(kChunks * kPoints));
}

TEST(JobAssembler, ScannerKindAndBudgetDefaults) {
  v1::JobHeader h;
  h.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  h.add_scans()->set_uncertainty(0.05);
  h.set_total_points(1);
  JobAssembler assembler(JobLimits{.default_budget_seconds = 7});
  ASSERT_TRUE(assembler.Add(Header(h)).ok());
  v1::ProcessRequest chunk;
  for (int i = 0; i < 3; ++i) chunk.mutable_points()->add_xyz(1.f);
  ASSERT_TRUE(assembler.Add(chunk).ok());
  ASSERT_TRUE(assembler.Add(End({chunk})).ok());
  auto job = assembler.Finish();
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->cloud.kind, ScannerKind::kFlexible);  // no scanline spacing anywhere
  EXPECT_EQ(job->cloud.scans[0].uncertainty, 0.05);
  EXPECT_EQ(job->options.budget_seconds, 7);
  EXPECT_TRUE(job->warnings.empty());
}

TEST(JobAssembler, RejectsABadDirection) {
  v1::JobHeader h = InchHeader();
  h.mutable_scans(0)->mutable_view_direction()->set_x(0);
  JobAssembler assembler(JobLimits{});
  const absl::Status s = assembler.Add(Header(h));
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "header.scans[0].view_direction: must be a finite non-zero vector");
}

absl::Status AddScan(v1::LengthUnit unit, const v1::ScanHeader& scan) {
  v1::JobHeader h;
  h.set_unit(unit);
  h.set_total_points(1);
  *h.add_scans() = scan;
  return JobAssembler(JobLimits{}).Add(Header(h));
}

TEST(JobAssembler, ScannerLengthsAreZeroOrFromOneNanometreToTenMetres) {
  v1::ScanHeader scan;
  scan.set_scanline_spacing(1e300);  // was accepted, and the job came back with 2 of 2,000 points
  absl::Status s = AddScan(v1::LENGTH_UNIT_MILLIMETRE, scan);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(),
            "header.scans[0].scanline_spacing: must be 0 or a length in "
            "[1e-06, 10000] mm, got 1e+300 (1e+300 mm)");

  // The bound holds after unit conversion: 10 m is the largest, 10.001 m is not.
  v1::ScanHeader metres;
  metres.set_uncertainty(10);
  EXPECT_TRUE(AddScan(v1::LENGTH_UNIT_METRE, metres).ok());
  metres.set_uncertainty(10.001);
  s = AddScan(v1::LENGTH_UNIT_METRE, metres);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(),
            "header.scans[0].uncertainty: must be 0 or a length in "
            "[1e-06, 10000] mm, got 10.001 (10001 mm)");

  // 1 nm is the smallest; 1e-300 mm underflowed the derived spacings to 0.
  v1::ScanHeader micrometres;
  micrometres.set_scanline_spacing(0.001);
  EXPECT_TRUE(AddScan(v1::LENGTH_UNIT_MICROMETRE, micrometres).ok());
  micrometres.set_scanline_spacing(1e-300);
  s = AddScan(v1::LENGTH_UNIT_MICROMETRE, micrometres);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), ::testing::HasSubstr("scanline_spacing: must be 0 or a length in "));

  for (double bad :
       {-0.5, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    v1::ScanHeader point_spacing;
    point_spacing.set_point_spacing(bad);
    s = AddScan(v1::LENGTH_UNIT_MILLIMETRE, point_spacing);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(s.message(), ::testing::HasSubstr("header.scans[0].point_spacing: must be 0 or a "
                                                  "length in [1e-06, 10000] mm"));
  }
}

TEST(JobAssembler, ScannerPositionsAndDirectionsAreBounded) {
  v1::ScanHeader far;
  far.mutable_camera_position()->set_x(2e6);  // finite, but 2,000 km in metres
  const absl::Status s = AddScan(v1::LENGTH_UNIT_METRE, far);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(),
            "header.scans[0].camera_position: must be within 1e+09 mm of the origin "
            "in the common frame");

  // Components whose squared norm overflows still give a unit direction, not a zero vector.
  v1::JobHeader h;
  h.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  h.set_total_points(1);
  h.add_scans()->mutable_view_direction()->set_y(1e200);
  JobAssembler assembler(JobLimits{});
  ASSERT_TRUE(assembler.Add(Header(h)).ok());
  v1::ProcessRequest chunk;
  for (int i = 0; i < 3; ++i) chunk.mutable_points()->add_xyz(1.f);
  ASSERT_TRUE(assembler.Add(chunk).ok());
  ASSERT_TRUE(assembler.Add(End({chunk})).ok());
  auto job = assembler.Finish();
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_TRUE(job->cloud.scans[0].view_direction->isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));

  v1::ScanHeader zero;
  zero.mutable_projector_direction()->set_z(0);
  EXPECT_EQ(AddScan(v1::LENGTH_UNIT_MILLIMETRE, zero).message(),
            "header.scans[0].projector_direction: must be a finite non-zero vector");
}

TEST(JobAssembler, RequiresTheDeclaredPointCount) {
  const absl::Status undeclared = JobAssembler(JobLimits{}).Add(Header(InchHeader()));
  EXPECT_EQ(undeclared.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(undeclared.message(), ::testing::HasSubstr("header.total_points = 0: the number of "
                                                         "points the upload will send must be "
                                                         "declared"));
}

// One point in one chunk, after a header that declares `total_points`.
struct OnePointUpload {
  explicit OnePointUpload(uint64_t total_points = 1) {
    v1::JobHeader h = InchHeader();
    h.set_total_points(total_points);
    EXPECT_TRUE(assembler.Add(Header(h)).ok());
    for (int i = 0; i < 3; ++i) chunk.mutable_points()->add_xyz(1.f);
    EXPECT_TRUE(assembler.Add(chunk).ok());
  }
  JobAssembler assembler{JobLimits{}};
  v1::ProcessRequest chunk;
};

// A stream ends at a message that fails to parse as at a half-close: only the end message shows
// that the upload is whole, even when every declared point arrived.
TEST(JobAssembler, AnUploadWithoutItsEndMessageIsRefused) {
  OnePointUpload upload;
  const auto job = upload.assembler.Finish();
  EXPECT_EQ(job.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(job.status().message()),
              ::testing::StartsWith("the upload ended without its end message after 1 of "
                                    "header.total_points = 1 points: the stream was cut"));
}

TEST(JobAssembler, TheEndMessagesCountMustMatchTheReceivedAndTheDeclaredCount) {
  OnePointUpload fewer(2);  // declared 2, sent 1, end says 1
  absl::Status s = fewer.assembler.Add(End({fewer.chunk}));
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(),
            "end.points = 1 but 1 points were received and header.total_points = 2; "
            "the three must agree");

  OnePointUpload miscounted;
  v1::ProcessRequest end = End({miscounted.chunk});
  end.mutable_end()->set_points(2);
  s = miscounted.assembler.Add(end);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(),
            "end.points = 2 but 1 points were received and header.total_points = 1; "
            "the three must agree");
}

TEST(JobAssembler, AChecksumMismatchIsDataLossNamingBothValues) {
  OnePointUpload upload;
  v1::ProcessRequest end = End({upload.chunk});
  const uint32_t right = end.end().crc32();
  end.mutable_end()->set_crc32(right ^ 1);
  const absl::Status s = upload.assembler.Add(end);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(s.message(), absl::StrFormat("end.crc32 = 0x%08x but the 1 points received have "
                                         "CRC-32 0x%08x: the upload was corrupted in transfer",
                                         right ^ 1, right));
}

TEST(JobAssembler, TheEndMessageIsLast) {
  OnePointUpload upload(2);
  ASSERT_TRUE(upload.assembler.Add(upload.chunk).ok());
  ASSERT_TRUE(upload.assembler.Add(End({upload.chunk, upload.chunk})).ok());
  for (const v1::ProcessRequest& late : {upload.chunk, End({upload.chunk, upload.chunk})}) {
    const absl::Status s = upload.assembler.Add(late);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(s.message(),
              "a message after the end message (which declared 2 points); the end "
              "message must be the upload's last");
  }

  const absl::Status first = JobAssembler(JobLimits{}).Add(End({}));
  EXPECT_EQ(first.message(), "first message must be a header (got the end message)");
}

}  // namespace
}  // namespace scanprep::server
