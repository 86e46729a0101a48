// SPDX-License-Identifier: Apache-2.0
// PointChunk.source_index (issue 40 item 7): each returned point names its position in the upload,
// so that a client gives back the fields it never sent (a file's colour). Ground truth is the
// upload itself: the positions of the points the server left out (NaN) are known, so every kept
// point's position is, and the point found there is the one that came back. The control asks for
// no positions and gets no bytes for them.
#include <cmath>
#include <limits>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/job/job_assembler.h"
#include "server/job/upload_positions.h"
#include "tests/server/service_fixtures.h"
#include "wire/chunk_arrays.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

// The plane with spikes, every 997th point without a position (the server leaves it out). The
// spikes' heights (2.5-10 mm) make a point returned under a wrong position stand out.
struct UploadWithHoles {
  GeneratedScan scan = NoisyPlaneWithSpikes(200, 0.5f);  // 40 k points: two chunks
  std::set<uint32_t> holes;
  UploadWithHoles() {
    for (uint32_t i = 5; i < scan.cloud.size(); i += 997) {
      scan.cloud.z[i] = std::numeric_limits<float>::quiet_NaN();
      holes.insert(i);
    }
  }
};

absl::StatusOr<client::ProcessResult> RunJob(
    const InProcessServer& server, const PointCloud& cloud, bool positions, bool include_removed,
    v1::ArrayEncoding arrays = v1::ARRAY_ENCODING_REPEATED) {
  v1::JobHeader header = SimpleHeader();
  header.set_return_source_index(positions);
  header.set_result_arrays(arrays);
  header.mutable_options()->set_include_removed(include_removed);
  return server.Client().Process(header, cloud, {.timeout = absl::Seconds(120)});
}

TEST(SourceIndex, EachReturnedPointNamesWhereItWasUploaded) {
  InProcessServer server;
  const UploadWithHoles upload;
  const PointCloud& sent = upload.scan.cloud;
  auto result = RunJob(server, sent, true, false);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->report.points_invalid(), upload.holes.size());
  ASSERT_EQ(result->source_index.size(), result->cloud.size());
  uint32_t previous = 0;
  for (size_t k = 0; k < result->cloud.size(); ++k) {
    const uint32_t at = result->source_index[k];
    ASSERT_LT(at, sent.size());
    ASSERT_TRUE(k == 0 || at > previous) << "positions increase: " << k;
    previous = at;
    ASSERT_FALSE(upload.holes.contains(at)) << k;
    // The point at that position is the one returned: unmoved unless smoothed, and then by a
    // few noise σ (0.025 mm), less than half the 0.5 mm to a neighbour.
    const float moved = (result->cloud.flags[k] & kSmoothed) ? 0.2f : 0.f;
    ASSERT_NEAR(result->cloud.x[k], sent.x[at], moved) << k;
    ASSERT_NEAR(result->cloud.y[k], sent.y[at], moved) << k;
    ASSERT_NEAR(result->cloud.z[k], sent.z[at], moved) << k;
  }
}

TEST(SourceIndex, WithTheRemovedPointsEveryValidPositionComesBackOnce) {
  InProcessServer server;
  const UploadWithHoles upload;
  auto result = RunJob(server, upload.scan.cloud, true, true, v1::ARRAY_ENCODING_PACKED);
  ASSERT_TRUE(result.ok()) << result.status();  // the packed positions pass the CRC check
  std::vector<uint32_t> expected;
  for (uint32_t i = 0; i < upload.scan.cloud.size(); ++i) {
    if (!upload.holes.contains(i)) expected.push_back(i);
  }
  EXPECT_EQ(result->source_index, expected);
}

TEST(SourceIndex, NotAskedForItCostsNothing) {
  InProcessServer server;
  const UploadWithHoles upload;
  auto result = RunJob(server, upload.scan.cloud, false, false);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_TRUE(result->source_index.empty());
  EXPECT_GT(result->cloud.size(), 0u);
}

TEST(SourceIndex, IsNotAnUploadField) {
  v1::JobHeader header = SimpleHeader();
  header.set_total_points(1);
  v1::ProcessRequest request;
  *request.mutable_header() = header;
  server::JobAssembler assembler({});
  ASSERT_TRUE(assembler.Add(request).ok());
  v1::PointChunk chunk;
  chunk.add_xyz(0), chunk.add_xyz(0), chunk.add_xyz(0);
  chunk.add_scanline(0);
  chunk.add_source_index(0);
  request.Clear();
  *request.mutable_points() = chunk;
  const absl::Status status = assembler.Add(request);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(status.message(), HasSubstr("source_index"));
  // Control: the same chunk without it is taken.
  server::JobAssembler control({});
  request.Clear();
  *request.mutable_header() = header;
  ASSERT_TRUE(control.Add(request).ok());
  request.Clear();
  *request.mutable_points() = chunk;
  request.mutable_points()->clear_source_index();
  const absl::Status taken = control.Add(request);
  EXPECT_TRUE(taken.ok()) << taken;
}

TEST(UploadPositions, CountTheExcludedPointsBeforeEachKeptOne) {
  // Uploaded 0..7 with 0, 1 and 5 left out: the cloud holds 2, 3, 4, 6, 7.
  server::UploadPositions positions;
  for (uint64_t excluded : {0, 1, 5}) positions.Exclude(excluded);
  const std::vector<uint64_t> expected = {2, 3, 4, 6, 7};
  for (uint64_t i = 0; i < expected.size(); ++i) EXPECT_EQ(positions.Of(i), expected[i]) << i;
  EXPECT_EQ(server::UploadPositions().Of(9), 9u);  // none left out: the identity
}

}  // namespace
}  // namespace scanprep::testing
