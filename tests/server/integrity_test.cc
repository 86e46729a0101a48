// SPDX-License-Identifier: Apache-2.0
// End-to-end integrity through the service: an upload ends with its end message (count and
// CRC-32) and a cut, miscounted or corrupted upload is refused, never processed; the result ends
// with one that the client checks before it uses the points.
#include <bit>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include "absl/strings/str_format.h"
#include "client/call_error.h"
#include "client/result_receiver.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

// A header declaring 300 points and three chunks of 100.
std::vector<v1::ProcessRequest> ThreeChunks() {
  std::vector<v1::ProcessRequest> requests = {HeaderRequest(SimpleHeader(), 300)};
  for (int c = 0; c < 3; ++c) {
    v1::PointChunk chunk = LineChunk(100);
    for (int i = 0; i < chunk.xyz_size(); i += 3) chunk.set_xyz(i + 1, static_cast<float>(c));
    requests.push_back(ChunkRequest(chunk));
  }
  return requests;
}

std::string ReasonOf(const grpc::Status& status) {
  return client::DetailsOf(client::FromGrpc(status)).reason;
}

class Integrity : public ::testing::Test {
 protected:
  InProcessServer server_;
  std::unique_ptr<v1::ScanPrep::Stub> stub_ = server_.Stub();
};

TEST_F(Integrity, AnUploadCutAnywhereIsRefusedNeverOk) {
  ASSERT_TRUE(RawCall(*stub_, ThreeChunks()).ok());  // the control: the same upload, ended
  // Cut after each chunk, including after the last: every declared point arrived, but only the
  // end message says that nothing more was meant to.
  for (size_t chunks = 0; chunks <= 3; ++chunks) {
    std::vector<v1::ProcessRequest> requests = ThreeChunks();
    requests.resize(1 + chunks);
    const grpc::Status status = RawCall(*stub_, requests, nullptr, Upload::kCut);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(status.error_message(),
                ::testing::StartsWith(absl::StrCat(
                    "the upload ended without its end message after ", 100 * chunks,
                    " of header.total_points = 300 points: the stream was cut (the client "
                    "half-closed early, or a message could not be parsed")));
    EXPECT_EQ(ReasonOf(status), "INCOMPLETE_UPLOAD");
  }
}

TEST_F(Integrity, APointCorruptedInFlightIsDataLossNamingBothChecksums) {
  std::vector<v1::ProcessRequest> requests = ThreeChunks();
  const v1::ProcessRequest end = EndRequest(requests);  // over the points as the client had them
  // One bit of one coordinate flips on the way: the lowest mantissa bit of point 150's y, a
  // change no plausibility check could see.
  v1::PointChunk& chunk = *requests[2].mutable_points();
  chunk.set_xyz(3 * 50 + 1, std::bit_cast<float>(std::bit_cast<uint32_t>(chunk.xyz(151)) ^ 1u));
  const uint32_t arrived = EndRequest(requests).end().crc32();
  ASSERT_NE(arrived, end.end().crc32());
  requests.push_back(end);

  const grpc::Status status = RawCall(*stub_, requests);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DATA_LOSS);
  EXPECT_EQ(status.error_message(),
            absl::StrFormat("end.crc32 = 0x%08x but the 300 points received have CRC-32 0x%08x: "
                            "the upload was corrupted in transfer",
                            end.end().crc32(), arrived));
  const absl::Status seen = client::FromGrpc(status);
  EXPECT_EQ(client::DetailsOf(seen).reason, "CHECKSUM_MISMATCH");
  EXPECT_TRUE(client::DetailsOf(seen).retry_delay.has_value());  // the same upload may succeed
  EXPECT_EQ(client::ExitCodeFor(seen), client::kExitRetryLater);
}

TEST_F(Integrity, ACountMismatchIsRefusedNamingEachCount) {
  std::vector<v1::ProcessRequest> requests = ThreeChunks();
  v1::ProcessRequest end = EndRequest(requests);
  end.mutable_end()->set_points(299);
  requests.push_back(end);
  grpc::Status status = RawCall(*stub_, requests);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "end.points = 299 but 300 points were received and "
            "header.total_points = 300; the three must agree");
  EXPECT_EQ(ReasonOf(status), "POINT_COUNT_MISMATCH");

  // A chunk lost on the way, ended by an end message for what arrived.
  requests = ThreeChunks();
  requests.erase(requests.begin() + 2);
  status = RawCall(*stub_, requests);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "end.points = 200 but 200 points were received and "
            "header.total_points = 300; the three must agree");
}

TEST_F(Integrity, NothingIsAcceptedAfterTheEndMessage) {
  std::vector<v1::ProcessRequest> requests = ThreeChunks();
  const v1::ProcessRequest last = requests.back();
  requests.pop_back();
  requests[0].mutable_header()->set_total_points(200);  // a whole upload, ended
  requests.push_back(EndRequest(requests));
  requests.push_back(last);
  const grpc::Status status = RawCall(*stub_, requests);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "a message after the end message (which declared 200 points); "
            "the end message must be the upload's last");
}

// A real result: a scan with spikes through outliers and normals, in two result chunks.
class ResultIntegrity : public Integrity {
 protected:
  void SetUp() override {
    const GeneratedScan scan = NoisyPlaneWithSpikes(200, 0.5f);
    v1::JobHeader header = SimpleHeader();
    header.mutable_options()->add_stages("outliers");
    header.mutable_options()->add_stages("normals");
    header_ = header;
    const std::vector<v1::ProcessRequest> requests = JobRequests(header, scan.cloud, 30'000);
    std::vector<v1::ProcessResponse> responses;
    ASSERT_TRUE(RawCall(*stub_, requests, &responses).ok());
    for (v1::ProcessResponse& r : responses) {
      if (!r.has_progress()) result_.push_back(std::move(r));
    }
    ASSERT_GE(result_.size(), 4u);  // at least two chunks, the report, the end message
  }

  absl::StatusOr<client::ProcessResult> Receive(std::vector<v1::ProcessResponse> messages) const {
    client::ResultReceiver receiver(header_);
    for (v1::ProcessResponse& m : messages) receiver.Add(m);
    return std::move(receiver).Finish();
  }

  v1::JobHeader header_;
  std::vector<v1::ProcessResponse> result_;  // without progress
};

TEST_F(ResultIntegrity, TheResultEndsWithTheCountAndCrc32OfItsPoints) {
  // The definition restated: one CRC-32 over every chunk's arrays, in field order, back to back.
  std::string bytes;
  uint64_t points = 0;
  auto append = [&bytes](const auto& array) {
    bytes.append(reinterpret_cast<const char*>(array.data()), array.size() * 4);
  };
  for (const v1::ProcessResponse& r : result_) {
    if (!r.has_points()) continue;
    const v1::PointChunk& c = r.points();
    points += c.xyz_size() / 3;
    append(c.xyz());
    append(c.scan_index());
    append(c.scanline());
    append(c.quality());
    append(c.intensity());
    append(c.normal());
    bytes += c.flags();
  }
  ASSERT_TRUE(result_[result_.size() - 2].has_report());
  ASSERT_TRUE(result_.back().has_end());
  const v1::StreamEnd& end = result_.back().end();
  EXPECT_EQ(end.points(), points);
  EXPECT_EQ(end.points(), result_[result_.size() - 2].report().points_returned());
  EXPECT_EQ(end.crc32(), crc32_z(0, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));

  auto received = Receive(result_);
  ASSERT_TRUE(received.ok()) << received.status();
  EXPECT_EQ(received->cloud.size(), points);
}

TEST_F(ResultIntegrity, TheClientRefusesAResultWithAFlippedBit) {
  std::vector<v1::ProcessResponse> flipped = result_;
  v1::PointChunk& chunk = *flipped[1].mutable_points();
  chunk.set_normal(7, std::bit_cast<float>(std::bit_cast<uint32_t>(chunk.normal(7)) ^ 1u));
  const auto received = Receive(flipped);
  EXPECT_EQ(received.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(received.status().message(), HasSubstr("the result was corrupted in transfer"));
  EXPECT_THAT(
      received.status().message(),
      HasSubstr(absl::StrFormat("end message has CRC-32 0x%08x", result_.back().end().crc32())));
  EXPECT_EQ(client::ExitCodeFor(received.status()), client::kExitRetryLater);
}

TEST_F(ResultIntegrity, TheClientRefusesACutOrShortenedResult) {
  std::vector<v1::ProcessResponse> cut = result_;
  cut.pop_back();  // no end message
  auto received = Receive(cut);
  EXPECT_EQ(received.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(received.status().message(), HasSubstr("the result ended without its end message"));

  std::vector<v1::ProcessResponse> short_by_a_chunk = result_;
  const uint64_t lost = short_by_a_chunk[0].points().xyz_size() / 3;
  short_by_a_chunk.erase(short_by_a_chunk.begin());
  received = Receive(short_by_a_chunk);
  EXPECT_EQ(received.status().code(), absl::StatusCode::kDataLoss);
  const uint64_t declared = result_.back().end().points();
  EXPECT_EQ(received.status().message(),
            absl::StrCat("the result's end message declares ", declared, " points and the report ",
                         declared, ", but ", declared - lost, " arrived"));
}

TEST_F(Integrity, TheClientLibraryEndsItsUploadAndChecksTheResult) {
  const GeneratedScan scan = NoisyPlaneWithSpikes(60, 0.5f);
  auto result = server_.Client().Process(SimpleHeader(), scan.cloud, {.chunk_points = 1000});
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->report.points_received(), scan.cloud.size());
  EXPECT_EQ(result->cloud.size(), result->report.points_returned());
}

}  // namespace
}  // namespace scanprep::testing
