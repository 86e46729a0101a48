// SPDX-License-Identifier: Apache-2.0
// The packed form of the per-point arrays (PointChunk.*_packed, JobHeader.result_arrays) carries
// the same job as the repeated form, and the report echoes the caller's labels with the server's
// version and the call's times.
#include <cstring>

#include <gmock/gmock.h>
#include <google/protobuf/util/time_util.h>
#include <gtest/gtest.h>

#include "absl/time/clock.h"
#include "tests/server/service_fixtures.h"
#include "wire/chunk_arrays.h"

namespace scanprep::testing {
namespace {

using google::protobuf::util::TimeUtil;
using ::testing::HasSubstr;

v1::JobHeader PlaneJob(v1::ArrayEncoding results) {
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->set_include_removed(true);
  header.set_result_arrays(results);
  return header;
}

// The responses' result chunks, each turned into the repeated form (the client library's view).
std::vector<v1::PointChunk> ResultChunks(const std::vector<v1::ProcessResponse>& responses,
                                         bool expect_packed) {
  std::vector<v1::PointChunk> chunks;
  for (const v1::ProcessResponse& r : responses) {
    if (!r.has_points()) continue;
    EXPECT_EQ(HasPackedArrays(r.points()), expect_packed);
    EXPECT_EQ(r.points().xyz_size() == 0, expect_packed);
    v1::PointChunk& chunk = chunks.emplace_back(r.points());
    std::string bad_array;
    EXPECT_TRUE(UnpackArrays(chunk, bad_array).ok()) << bad_array;
  }
  return chunks;
}

TEST(PackedArrays, UploadAndResultsPackedGiveTheSameJobAsRepeated) {
  InProcessServer server;
  auto stub = server.Stub();
  const GeneratedScan scan = NoisyPlaneWithSpikes(120, 0.5f);
  std::vector<v1::ProcessRequest> repeated =
      JobRequests(PlaneJob(v1::ARRAY_ENCODING_REPEATED), scan.cloud, 5'000);
  std::vector<v1::ProcessRequest> packed =
      JobRequests(PlaneJob(v1::ARRAY_ENCODING_PACKED), scan.cloud, 5'000);
  for (v1::ProcessRequest& r : packed) {
    if (r.has_points()) PackArrays(*r.mutable_points());
  }
  packed[0].mutable_header()->set_total_points(scan.cloud.size());
  std::vector<v1::ProcessResponse> from_repeated, from_packed;
  ASSERT_TRUE(RawCall(*stub, repeated, &from_repeated).ok());
  ASSERT_TRUE(RawCall(*stub, packed, &from_packed).ok());

  const std::vector<v1::PointChunk> a = ResultChunks(from_repeated, false);
  const std::vector<v1::PointChunk> b = ResultChunks(from_packed, true);
  ASSERT_EQ(a.size(), b.size());
  size_t points = 0;
  for (size_t c = 0; c < a.size(); ++c) {
    points += a[c].xyz_size() / 3;
    EXPECT_EQ(a[c].SerializeAsString(), b[c].SerializeAsString()) << "chunk " << c;
  }
  EXPECT_EQ(points, scan.cloud.size());  // include_removed: every point, normals and flags too
  ASSERT_GT(a.front().normal_size(), 0);
  ASSERT_FALSE(a.front().flags().empty());
}

TEST(PackedArrays, AnArrayInBothFormsOrCutMidValueIsRefusedByName) {
  InProcessServer server;
  auto stub = server.Stub();
  v1::PointChunk both = LineChunk(10);
  both.set_scanline_packed(std::string(40, '\0'));
  both.add_scanline(0);
  grpc::Status status = RawCall(*stub, {HeaderRequest(SimpleHeader(), 10), ChunkRequest(both)});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(),
              HasSubstr("chunk 0: scanline and scanline_packed are both set"));

  v1::PointChunk cut = LineChunk(10);
  PackArrays(cut);
  cut.mutable_xyz_packed()->pop_back();
  status = RawCall(*stub, {HeaderRequest(SimpleHeader(), 10), ChunkRequest(cut)});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(),
              HasSubstr("chunk 0: xyz_packed has 119 bytes, not a multiple of 4"));
}

TEST(PackedArrays, TheReportEchoesLabelsWithVersionAndTimes) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader();
  header.mutable_options()->add_stages("outliers");
  (*header.mutable_labels())["part_serial"] = "A-1234";
  (*header.mutable_labels())["station"] = "OP40";
  const absl::Time before = absl::Now();
  auto result = server.Client().Process(header, NoisyPlaneWithSpikes(60, 0.5f).cloud);
  const absl::Time after = absl::Now();
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::Report& report = result->report;
  EXPECT_EQ(report.labels().size(), 2u);
  EXPECT_EQ(report.labels().at("part_serial"), "A-1234");
  EXPECT_EQ(report.labels().at("station"), "OP40");
  auto info = server.Client().GetInfo();
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(report.server_version(), info->version());
  EXPECT_FALSE(report.server_version().empty());
  const int64_t started = TimeUtil::TimestampToNanoseconds(report.started());
  const int64_t finished = TimeUtil::TimestampToNanoseconds(report.finished());
  EXPECT_LE(absl::ToUnixNanos(before), started);
  EXPECT_LE(started, finished);
  EXPECT_LE(finished, absl::ToUnixNanos(after));
}

TEST(PackedArrays, LabelsAreBounded) {
  InProcessServer server;
  auto stub = server.Stub();
  v1::JobHeader many = SimpleHeader();
  for (int i = 0; i <= server::kMaxLabels; ++i) {
    (*many.mutable_labels())[absl::StrCat("k", i)] = "v";
  }
  grpc::Status status = RawCall(*stub, {HeaderRequest(many, 10)});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("header.labels has 33 entries; at most 32"));
  v1::JobHeader long_value = SimpleHeader();
  (*long_value.mutable_labels())["serial"] = std::string(300, 's');
  status = RawCall(*stub, {HeaderRequest(long_value, 10)});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(),
              HasSubstr("header.labels['serial']: the value is 300 bytes long"));
}

}  // namespace
}  // namespace scanprep::testing
