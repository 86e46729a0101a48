// SPDX-License-Identifier: Apache-2.0
// Inputs assembler_fuzzer (tests/fuzz) found mishandled by the JobAssembler, inlined.
#include <cmath>

#include <gtest/gtest.h>

#include "server/job/job_assembler.h"

namespace scanprep::server {
namespace {

// A finite coordinate that leaves the float range once converted to millimetres (3e38 m) or moved
// by a finite translation (1e300 mm) must not reach the pipeline as an infinite coordinate: it is
// either excluded like a NaN point or the job is refused with INVALID_ARGUMENT.
void ExpectNoInfiniteCoordinates(v1::LengthUnit unit, double translation_x, float x) {
  JobAssembler assembler(JobLimits{});
  v1::ProcessRequest header;
  header.mutable_header()->set_unit(unit);
  header.mutable_header()->set_total_points(2);
  header.mutable_header()->add_scans()->mutable_to_common()->mutable_translation()->set_x(
      translation_x);
  if (const absl::Status s = assembler.Add(header); !s.ok()) {
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
    EXPECT_NE(s.message().find("to_common.translation"), std::string::npos) << s;
    return;
  }
  v1::ProcessRequest chunk;
  for (float v : {x, 0.f, 0.f, 1.f, 2.f, 3.f}) chunk.mutable_points()->add_xyz(v);
  StreamChecksum checksum;
  checksum.Add(chunk.points());
  v1::ProcessRequest end;
  *end.mutable_end() = checksum.End();
  absl::Status added = assembler.Add(chunk);
  if (added.ok()) added = assembler.Add(end);
  absl::StatusOr<AssembledJob> job =
      added.ok() ? assembler.Finish() : absl::StatusOr<AssembledJob>(added);
  if (!job.ok()) {
    EXPECT_EQ(job.status().code(), absl::StatusCode::kInvalidArgument) << job.status();
    return;
  }
  const PointCloud& cloud = job->cloud;
  for (size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_TRUE(cloud.point(i).allFinite()) << "point " << i << ": " << cloud.point(i).transpose();
  }
  EXPECT_EQ(cloud.size() + job->points_invalid, job->points_received);
}

TEST(AssemblerFuzzRegressions, CoordinateOverflowingFloatAfterUnitConversion) {
  ExpectNoInfiniteCoordinates(v1::LENGTH_UNIT_METRE, 0.0, 3e38f);
}

TEST(AssemblerFuzzRegressions, CoordinateOverflowingFloatAfterTranslation) {
  ExpectNoInfiniteCoordinates(v1::LENGTH_UNIT_MILLIMETRE, 1e300, 1.f);
}

}  // namespace
}  // namespace scanprep::server
