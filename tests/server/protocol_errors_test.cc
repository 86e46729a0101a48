// SPDX-License-Identifier: Apache-2.0
// Every malformed request ends the call with a precise status: the code and a message that
// names the problem (field, chunk number or limit).
#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

class ProtocolErrors : public ::testing::Test {
 protected:
  // Header then chunks, as one raw call.
  grpc::Status Send(const v1::JobHeader& header, const std::vector<v1::PointChunk>& chunks,
                    std::vector<v1::ProcessResponse>* responses = nullptr) {
    std::vector<v1::ProcessRequest> requests = {HeaderRequest(header)};
    for (const auto& c : chunks) requests.push_back(ChunkRequest(c));
    return RawCall(*stub_, requests, responses);
  }

  InProcessServer server_;
  std::unique_ptr<v1::ScanPrep::Stub> stub_ = server_.Stub();
};

#define EXPECT_STATUS(status, code, text)               \
  do {                                                  \
    const grpc::Status s_ = (status);                   \
    EXPECT_EQ(s_.error_code(), grpc::StatusCode::code); \
    EXPECT_THAT(s_.error_message(), HasSubstr(text));   \
  } while (0)

TEST_F(ProtocolErrors, PointsBeforeHeader) {
  EXPECT_STATUS(RawCall(*stub_, {ChunkRequest(LineChunk(10))}), INVALID_ARGUMENT,
                "first message must be a header");
}

TEST_F(ProtocolErrors, EmptyStream) {
  EXPECT_STATUS(RawCall(*stub_, {}), INVALID_ARGUMENT, "first message must be a header");
}

TEST_F(ProtocolErrors, SecondHeader) {
  EXPECT_STATUS(RawCall(*stub_, {HeaderRequest(SimpleHeader()), ChunkRequest(LineChunk(10)),
                                 HeaderRequest(SimpleHeader())}),
                INVALID_ARGUMENT, "a second header");
}

TEST_F(ProtocolErrors, HeaderWithoutScans) {
  v1::JobHeader header = SimpleHeader();
  header.clear_scans();
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "header.scans: a job needs at least one scan");
}

TEST_F(ProtocolErrors, UnitUnspecified) {
  v1::JobHeader header = SimpleHeader();
  header.clear_unit();
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "header.unit: the length unit must be stated");
}

TEST_F(ProtocolErrors, UnknownStage) {
  v1::JobHeader header = SimpleHeader();
  header.mutable_options()->add_stages("sharpen");
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT, "unknown stage 'sharpen'");
}

TEST_F(ProtocolErrors, UnknownParameter) {
  v1::JobHeader header = SimpleHeader();
  (*header.mutable_options()->mutable_params())["outliers.sigma"] = "2";
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "options.params['outliers.sigma']: unknown parameter");
}

TEST_F(ProtocolErrors, ParameterNotANumber) {
  v1::JobHeader header = SimpleHeader();
  (*header.mutable_options()->mutable_params())["outliers.multiplier"] = "two";
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "options.params['outliers.multiplier']: 'two' is not a finite number");
}

TEST_F(ProtocolErrors, NegativeStageBudget) {
  v1::JobHeader header = SimpleHeader();
  (*header.mutable_budget()->mutable_stage_seconds())["outliers"] = -1;
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "budget.stage_seconds['outliers']");
}

TEST_F(ProtocolErrors, RotationNotAUnitQuaternion) {
  v1::JobHeader header = SimpleHeader();
  header.mutable_scans(0)->mutable_to_common()->mutable_rotation()->set_w(2);
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "header.scans[0].to_common.rotation: must be a unit quaternion");
}

TEST_F(ProtocolErrors, AbsurdScannerMetadata) {
  EXPECT_STATUS(Send(SimpleHeader(1e300), {LineChunk(2000)}), INVALID_ARGUMENT,
                "header.scans[0].scanline_spacing: must be 0 or a length in [1e-06, 10000] mm, got "
                "1e+300");
}

TEST_F(ProtocolErrors, XyzNotAMultipleOfThree) {
  v1::PointChunk bad = LineChunk(10);
  bad.add_xyz(1.f);
  EXPECT_STATUS(Send(SimpleHeader(), {LineChunk(10), LineChunk(10), bad}), INVALID_ARGUMENT,
                "chunk 2: xyz has 31 floats, not a multiple of 3");
}

TEST_F(ProtocolErrors, ArraysDisagreeInLength) {
  v1::PointChunk bad = LineChunk(10);
  for (int i = 0; i < 9; ++i) bad.add_scanline(0);
  EXPECT_STATUS(Send(SimpleHeader(), {LineChunk(10), bad}), INVALID_ARGUMENT,
                "chunk 1: scanline has 9 values but xyz has 10 points");
}

TEST_F(ProtocolErrors, ArrayMissingFromALaterChunk) {
  v1::PointChunk with_quality = LineChunk(10);
  for (int i = 0; i < 10; ++i) with_quality.add_quality(0.5f);
  EXPECT_STATUS(Send(SimpleHeader(), {with_quality, LineChunk(10)}), INVALID_ARGUMENT,
                "chunk 1: quality is missing");
}

TEST_F(ProtocolErrors, ScanIndexNotDeclared) {
  v1::JobHeader header = SimpleHeader();
  header.add_scans()->set_scan_id("second");
  v1::PointChunk chunk = LineChunk(4);
  for (uint32_t s : {0u, 1u, 2u, 0u}) chunk.add_scan_index(s);
  EXPECT_STATUS(Send(header, {chunk}), INVALID_ARGUMENT,
                "chunk 0: scan_index[2] = 2 is not a scan declared in the header (2 scans)");
}

TEST_F(ProtocolErrors, ScanIndexMissingWithSeveralScans) {
  v1::JobHeader header = SimpleHeader();
  header.add_scans()->set_scan_id("second");
  EXPECT_STATUS(Send(header, {LineChunk(4)}), INVALID_ARGUMENT, "chunk 0: scan_index is required");
}

TEST_F(ProtocolErrors, QualityOutOfRange) {
  v1::PointChunk chunk = LineChunk(3);
  for (float q : {0.5f, 1.5f, 0.f}) chunk.add_quality(q);
  EXPECT_STATUS(Send(SimpleHeader(), {chunk}), INVALID_ARGUMENT,
                "chunk 0: quality[1] = 1.5 is outside [0, 1]");
}

TEST_F(ProtocolErrors, ChunkLargerThanTheLimit) {
  EXPECT_STATUS(Send(SimpleHeader(), {LineChunk(65'537)}), RESOURCE_EXHAUSTED,
                "chunk 0: 65537 points exceed the limit of 65536 points per chunk");
}

TEST_F(ProtocolErrors, ZeroPoints) {
  EXPECT_STATUS(Send(SimpleHeader(), {}), INVALID_ARGUMENT,
                "header.total_points = 0: the number of points the upload will send must be "
                "declared");
}

TEST_F(ProtocolErrors, UndeclaredPointCountIsRefusedAtTheHeader) {
  grpc::ClientContext context;
  auto stream = stub_->Process(&context);
  ASSERT_TRUE(stream->Write(HeaderRequest(SimpleHeader())));
  stream->Write(ChunkRequest(LineChunk(10)));
  stream->WritesDone();
  v1::ProcessResponse response;
  EXPECT_FALSE(stream->Read(&response));  // refused before any point was acknowledged
  EXPECT_STATUS(stream->Finish(), INVALID_ARGUMENT, "header.total_points = 0");
}

// Request messages as bytes, so a test can send what no client library would: gRPC ends the
// server's stream at a message that fails to parse as if the client had half-closed.
grpc::Status BytesCall(const std::string& target, const std::vector<std::string>& messages) {
  auto channel = grpc::CreateChannel(target, grpc::InsecureChannelCredentials());
  const grpc::internal::RpcMethod method("/scanprep.v1.ScanPrep/Process",
                                         grpc::internal::RpcMethod::BIDI_STREAMING);
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          channel.get(), method, &context));
  for (const std::string& m : messages) {
    const grpc::Slice slice(m);
    grpc::ByteBuffer buffer(&slice, 1);
    if (!stream->Write(buffer)) break;
  }
  stream->WritesDone();
  grpc::ByteBuffer response;
  while (stream->Read(&response)) {
  }
  return stream->Finish();
}

TEST_F(ProtocolErrors, AHeaderThatFailsToParseIsNotCalledAnEmptyStream) {
  v1::JobHeader header = SimpleHeader();
  header.set_total_points(10);
  header.set_job_id("caf\xe9");  // Latin-1, not UTF-8: proto3 strings must be UTF-8
  EXPECT_STATUS(BytesCall(server_.target(), {HeaderRequest(header).SerializeAsString(),
                                             ChunkRequest(LineChunk(10)).SerializeAsString()}),
                INVALID_ARGUMENT,
                "first message must be a header (the stream ended before one arrived: none was "
                "sent, or a message could not be parsed: a malformed encoding, or invalid UTF-8 "
                "in a string field such as job_id or scan_id)");
}

TEST_F(ProtocolErrors, AMessageThatFailsToParseMidStreamIsNeverOk) {
  v1::JobHeader header = SimpleHeader();
  header.set_total_points(30);
  const v1::ProcessRequest chunk_request = ChunkRequest(LineChunk(10));
  const std::string chunk = chunk_request.SerializeAsString();
  const std::string end =
      EndRequest({chunk_request, chunk_request, chunk_request}).SerializeAsString();
  // The control: all three chunks intact and the end message is a complete job.
  ASSERT_TRUE(BytesCall(server_.target(),
                        {HeaderRequest(header).SerializeAsString(), chunk, chunk, chunk, end})
                  .ok());
  // The third chunk cut inside its length varint (after a byte with the continuation bit set),
  // or led by a field of wire type 7, which does not exist: the stream ends there, and the end
  // message the client sent after it never arrives.
  const std::string truncated_varint = chunk.substr(0, 1) + "\xfb";
  const std::string bad_wire_type = "\x17" + chunk;
  for (const std::string& bad : {truncated_varint, bad_wire_type}) {
    EXPECT_STATUS(BytesCall(server_.target(),
                            {HeaderRequest(header).SerializeAsString(), chunk, chunk, bad, end}),
                  INVALID_ARGUMENT,
                  "the upload ended without its end message after 20 of header.total_points = 30 "
                  "points: the stream was cut");
  }
}

TEST_F(ProtocolErrors, OnlyInvalidPoints) {
  v1::PointChunk chunk;
  for (int i = 0; i < 3; ++i) {
    chunk.add_xyz(std::numeric_limits<float>::quiet_NaN());
    chunk.add_xyz(0);
    chunk.add_xyz(0);
  }
  EXPECT_STATUS(Send(SimpleHeader(), {chunk}), INVALID_ARGUMENT,
                "the job has no valid points: all 3 have NaN, infinite or out-of-range (> 1e+09 "
                "mm) coordinates");
}

TEST_F(ProtocolErrors, TotalPointsMismatch) {
  v1::JobHeader header = SimpleHeader();
  header.set_total_points(30);
  EXPECT_STATUS(Send(header, {LineChunk(10)}), INVALID_ARGUMENT,
                "end.points = 10 but 10 points were received and header.total_points = 30");
}

TEST(ProtocolLimits, MorePointsThanTheJobLimitEndsTheCallWhenCrossed) {
  server::ServerOptions options;
  options.limits.max_points_per_job = 1000;
  InProcessServer server(options);
  auto stub = server.Stub();
  std::vector<v1::ProcessResponse> responses;
  // The declared total is within the limit, so points beyond it cross the limit too.
  const grpc::Status status =
      RawCall(*stub,
              {HeaderRequest(SimpleHeader(), 1000), ChunkRequest(LineChunk(600)),
               ChunkRequest(LineChunk(600)), ChunkRequest(LineChunk(600))},
              &responses);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(),
              HasSubstr("chunk 1: more points than header.total_points = 1000"));
  // Only the first chunk was acknowledged: the call ended at the crossing chunk.
  ASSERT_EQ(responses.size(), 1u);
  EXPECT_EQ(responses[0].progress().points(), 600u);

  // An announced total over the limit is refused before any upload.
  v1::JobHeader header = SimpleHeader();
  header.set_total_points(5000);
  const grpc::Status early = RawCall(*stub, {HeaderRequest(header)});
  EXPECT_EQ(early.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(early.error_message(), HasSubstr("header.total_points = 5000 exceeds"));
}

TEST(ProtocolLimits, CallsBeyondTheConcurrencyLimitAreRefusedAtOnce) {
  server::ServerOptions options;
  options.max_concurrent_jobs = 1;
  options.max_queued_jobs = 0;  // no waiting room: admission_test covers the queue
  InProcessServer server(options);
  auto stub = server.Stub();

  // Hold the only ticket: an open upload whose first chunk the server acknowledged.
  grpc::ClientContext held;
  auto stream = stub->Process(&held);
  ASSERT_TRUE(stream->Write(HeaderRequest(SimpleHeader(), 100)));
  ASSERT_TRUE(stream->Write(ChunkRequest(LineChunk(100))));
  v1::ProcessResponse ack;
  ASSERT_TRUE(stream->Read(&ack));

  const grpc::Status refused =
      RawCall(*stub, {HeaderRequest(SimpleHeader()), ChunkRequest(LineChunk(100))});
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(),
              HasSubstr("its limit of 1 jobs (max_concurrent_jobs 1 + max_queued_jobs 0): 0 "
                        "running, 0 waiting for a slot, 1 uploading"));

  // The held call completes normally, and frees its ticket.
  ASSERT_TRUE(stream->Write(EndRequest({ChunkRequest(LineChunk(100))})));
  stream->WritesDone();
  while (stream->Read(&ack)) {
  }
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_TRUE(RawCall(*stub, {HeaderRequest(SimpleHeader()), ChunkRequest(LineChunk(100))}).ok());
}

}  // namespace
}  // namespace scanprep::testing
