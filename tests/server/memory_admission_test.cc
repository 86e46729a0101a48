// SPDX-License-Identifier: Apache-2.0
// Memory-aware admission through the real service: a job whose estimated memory exceeds the
// server's whole memory capacity is refused at its header with the numbers a program needs
// (ErrorInfo metadata), a larger neighbourhoods.k raises the estimate, and GetInfo reports the
// capacity. The measured test (peak RSS of a server of a small capacity) is in subprocess_test.cc.
#include <map>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/call_error.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "server/admission/memory_reservation.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

constexpr uint64_t kCapacity = uint64_t{64} << 20;

struct ErrorInfo {
  std::string reason;
  std::map<std::string, std::string> metadata;
  bool retry_info = false;
};

// The ErrorInfo and whether a RetryInfo came, as a client parses the status details.
ErrorInfo ParseErrorInfo(const grpc::Status& status) {
  ErrorInfo parsed;
  google::rpc::Status rpc;
  EXPECT_TRUE(rpc.ParseFromString(status.error_details()));
  for (const google::protobuf::Any& any : rpc.details()) {
    google::rpc::ErrorInfo info;
    if (any.UnpackTo(&info)) {
      parsed.reason = info.reason();
      parsed.metadata.insert(info.metadata().begin(), info.metadata().end());
    }
    parsed.retry_info |= any.Is<google::rpc::RetryInfo>();
  }
  return parsed;
}

// A header declaring `points` and then a half-close: the call ends at admission when refused,
// else as an upload that fell short of its declared count.
grpc::Status HeaderOnly(const InProcessServer& server, uint64_t points,
                        const std::map<std::string, std::string>& params = {}) {
  v1::JobHeader header = SimpleHeader();
  for (const auto& [name, value] : params) {
    (*header.mutable_options()->mutable_params())[name] = value;
  }
  return RawCall(*server.Stub(), {HeaderRequest(header, points)});
}

TEST(MemoryAdmission, AJobLargerThanTheCapacityIsRefusedAtItsHeaderWithTheNumbers) {
  InProcessServer server({.memory_capacity_bytes = kCapacity});
  // 200,000 points: 16 MiB + 200,000 x 416 B = 99,977,216 bytes, over the 67,108,864 capacity.
  const grpc::Status status = HeaderOnly(server, 200'000);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(),
              HasSubstr("estimated memory of 95 MiB (99977216 bytes, from header.total_points) "
                        "exceeds the server's whole memory capacity of 64 MiB (67108864 bytes, "
                        "memory_capacity)"));
  const ErrorInfo info = ParseErrorInfo(status);
  EXPECT_EQ(info.reason, "JOB_EXCEEDS_MEMORY");
  EXPECT_EQ(info.metadata.at("estimate_bytes"), "99977216");
  EXPECT_EQ(info.metadata.at("budget_bytes"), "67108864");
  EXPECT_FALSE(info.retry_info);  // it will never fit on this server
  EXPECT_EQ(client::ExitCodeFor(client::FromGrpc(status)), client::kExitFixInput);

  // 120,000 points (66,697,216 bytes) fit: admitted, then refused for the missing points.
  const grpc::Status fits = HeaderOnly(server, 120'000);
  EXPECT_EQ(fits.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << fits.error_message();
  EXPECT_THAT(fits.error_message(), HasSubstr("total_points"));
}

TEST(MemoryAdmission, ALargerNeighbourCountRaisesTheEstimate) {
  InProcessServer server({.memory_capacity_bytes = kCapacity});
  EXPECT_EQ(HeaderOnly(server, 80'000).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  // k = 64: 768 B/point, 80,000 points = 78,217,216 bytes.
  const grpc::Status status = HeaderOnly(server, 80'000, {{"neighbourhoods.k", "64"}});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(ParseErrorInfo(status).metadata.at("estimate_bytes"), "78217216");
}

TEST(MemoryAdmission, GetInfoReportsTheCapacityAndTheBytesPerPoint) {
  InProcessServer server({.memory_capacity_bytes = kCapacity});
  auto info = server.Client().GetInfo(absl::Seconds(10));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->limits().memory_budget_bytes(), kCapacity);
  EXPECT_EQ(info->limits().bytes_per_point(), server::kBytesPerPoint);
}

}  // namespace
}  // namespace scanprep::testing
