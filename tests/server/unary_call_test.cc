// SPDX-License-Identifier: Apache-2.0
// ProcessUnary (issue 40 item 3): one job in one message each way, run as the stream it stands
// for. The streamed call is the control: the same job gives the same points, flags and report;
// the unary call's own parts (the optional CRC, the one-chunk result and its end, the message
// limit) are checked on their own.
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "tests/server/service_fixtures.h"
#include "wire/chunk_arrays.h"
#include "wire/stream_checksum.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

grpc::Status CallUnary(const InProcessServer& server, const v1::ProcessUnaryRequest& request,
                       v1::ProcessUnaryResponse& response) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  return server.Stub()->ProcessUnary(&context, request, &response);
}

TEST(UnaryCall, AJobInOneMessageIsTheSameJobStreamed) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(300, 0.5f);  // 90 k points: three pieces
  ASSERT_GT(scan.cloud.size(), 2 * server::kRecommendedChunkPoints);
  v1::ProcessUnaryResponse unary;
  v1::ProcessUnaryRequest request = UnaryRequest(scan);
  request.mutable_header()->set_return_source_index(true);
  const grpc::Status status = CallUnary(server, request, unary);
  ASSERT_TRUE(status.ok()) << status.error_message();
  v1::JobHeader header = SimpleHeader();
  header.set_return_source_index(true);
  auto streamed = server.Client().Process(header, scan.cloud, {.timeout = absl::Seconds(120)});
  ASSERT_TRUE(streamed.ok()) << streamed.status();

  EXPECT_EQ(unary.report().points_received(), scan.cloud.size());
  EXPECT_EQ(unary.report().points_returned(), streamed->report.points_returned());
  v1::PointChunk points = unary.points();
  std::string bad;
  ASSERT_TRUE(UnpackArrays(points, bad).ok());
  ASSERT_EQ(static_cast<size_t>(points.xyz_size()), 3 * streamed->cloud.size());
  for (size_t i = 0; i < streamed->cloud.size(); ++i) {
    ASSERT_EQ(points.xyz(3 * i + 2), streamed->cloud.z[i]) << i;
    ASSERT_EQ(static_cast<uint8_t>(points.flags()[i]), streamed->cloud.flags[i]) << i;
    ASSERT_EQ(points.source_index(i), streamed->source_index[i]) << i;
  }
  // Ground truth, not only agreement: every spike is gone.
  size_t spikes = 0;
  for (bool s : scan.spike) spikes += s;
  ASSERT_GT(spikes, 0u);
  EXPECT_LE(unary.report().points_returned(), scan.cloud.size() - spikes);
  // The end counts and sums the one chunk, as a stream's end sums its chunks.
  StreamChecksum sum;
  sum.Add(unary.points());
  EXPECT_EQ(unary.end().points(), unary.report().points_returned());
  EXPECT_EQ(unary.end().crc32(), sum.crc32());
}

TEST(UnaryCall, TheCrcIsOptionalAndCheckedWhenGiven) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(60, 0.5f);
  v1::ProcessUnaryRequest request = UnaryRequest(scan);
  StreamChecksum sum;
  sum.Add(request.points());
  request.set_crc32(sum.crc32());
  v1::ProcessUnaryResponse response;
  EXPECT_TRUE(CallUnary(server, request, response).ok());
  request.set_crc32(sum.crc32() ^ 1);
  const grpc::Status corrupted = CallUnary(server, request, response);
  EXPECT_EQ(corrupted.error_code(), grpc::StatusCode::DATA_LOSS);
  EXPECT_THAT(corrupted.error_message(), HasSubstr("corrupted in transfer"));
}

TEST(UnaryCall, BadInputGetsTheStreamsTypedErrors) {
  InProcessServer server;
  v1::ProcessUnaryRequest request = UnaryRequest(NoisyPlaneWithSpikes(60, 0.5f));
  request.mutable_header()->set_unit(v1::LENGTH_UNIT_UNSPECIFIED);
  v1::ProcessUnaryResponse response;
  grpc::Status status = CallUnary(server, request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("unit"));
  // A count that does not match the header, found as the stream's end would find it.
  request = UnaryRequest(NoisyPlaneWithSpikes(60, 0.5f));
  request.mutable_header()->set_total_points(request.header().total_points() + 1);
  status = CallUnary(server, request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("header.total_points"));
}

TEST(UnaryCall, AJobAboveTheMessageLimitIsRefusedBeforeItIsRead) {
  server::ServerOptions options;
  options.limits.max_message_bytes = 1 << 20;
  InProcessServer server(options);
  const v1::ProcessUnaryRequest request = UnaryRequest(NoisyPlaneWithSpikes(300, 0.5f));
  ASSERT_GT(request.ByteSizeLong(), size_t{1} << 20);
  v1::ProcessUnaryResponse response;
  EXPECT_EQ(CallUnary(server, request, response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Control: a job within it runs.
  EXPECT_TRUE(CallUnary(server, UnaryRequest(NoisyPlaneWithSpikes(60, 0.5f)), response).ok());
}

// The answer is held to the same limit: it outlives the job's memory reservation until the
// client reads it. 58 k points sent as 0.93 MB come back with their normals as about 1.4 MB.
TEST(UnaryCall, AnAnswerAboveTheMessageLimitIsNotSent) {
  server::ServerOptions options;
  options.limits.max_message_bytes = 1 << 20;
  InProcessServer server(options);
  v1::ProcessUnaryRequest request = UnaryRequest(NoisyPlaneWithSpikes(240, 0.5f));
  // No simplification, which would thin the flat plate: every kept point comes back, normal too.
  for (const char* stage : {"outliers", "normals"}) {
    request.mutable_header()->mutable_options()->add_stages(stage);
  }
  ASSERT_LT(request.ByteSizeLong(), size_t{1} << 20);
  v1::ProcessUnaryResponse response;
  EXPECT_EQ(CallUnary(server, request, response).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Control: the same job with the default limit comes back whole.
  InProcessServer roomy;
  ASSERT_TRUE(CallUnary(roomy, request, response).ok());
  EXPECT_GT(response.ByteSizeLong(), size_t{1} << 20);
}

// The job docs/api.md sends with grpcurl, read as grpcurl reads it (protobuf's JSON mapping).
TEST(UnaryCall, TheDocumentedGrpcurlJobRuns) {
  std::ifstream in(std::string(SCANPREP_SOURCE_DIR) + "/client/examples/unary_job.json");
  const std::string json((std::istreambuf_iterator<char>(in)), {});
  ASSERT_FALSE(json.empty());
  v1::ProcessUnaryRequest request;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json, &request).ok());
  InProcessServer server;
  v1::ProcessUnaryResponse response;
  const grpc::Status status = CallUnary(server, request, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  // An 8 x 8 plate 0.5 mm apart and one point 5 mm above it: that one is removed.
  EXPECT_EQ(response.report().points_received(), 65u);
  EXPECT_EQ(response.report().points_returned(), 64u);
  v1::PointChunk returned = response.points();
  for (int i = 2; i < returned.xyz_size(); i += 3) EXPECT_EQ(returned.xyz(i), 0.f) << i / 3;
}

}  // namespace
}  // namespace scanprep::testing
