// What the client makes of a failed call: the server's ErrorInfo reason and RetryInfo delay reach
// the absl::Status, and the exit code says "retry later" exactly when a retry can succeed and "fix
// the input" when the job itself was refused.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/call_error.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

PointCloud Line(size_t n) {
  PointCloud cloud;
  for (size_t i = 0; i < n; ++i) {
    cloud.x.push_back(0.5f * i);
    cloud.y.push_back(0.f);
    cloud.z.push_back(0.f);
  }
  cloud.scans.push_back(ScanMeta{.id = "line"});
  cloud.FinishLoading();
  return cloud;
}

TEST(CallError, QueueFullSaysRetryLaterWithTheDelay) {
  InProcessServer server(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 0});
  auto stub = server.Stub();
  // Holds the only slot: the header and a chunk, acknowledged, never half-closed.
  grpc::ClientContext held_context;
  auto held = stub->Process(&held_context);
  ASSERT_TRUE(held->Write(HeaderRequest(SimpleHeader(), 100)));
  ASSERT_TRUE(held->Write(ChunkRequest(LineChunk(100))));
  v1::ProcessResponse ack;
  ASSERT_TRUE(held->Read(&ack));

  const auto refused = server.Client().Process(SimpleHeader(), Line(100));
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  const client::CallErrorDetails details = client::DetailsOf(refused.status());
  EXPECT_EQ(details.reason, "QUEUE_FULL");
  ASSERT_TRUE(details.retry_delay.has_value());
  EXPECT_GE(*details.retry_delay, absl::Seconds(1));
  EXPECT_THAT(client::Describe(refused.status()),
              HasSubstr("(reason QUEUE_FULL; retry after " +
                        absl::FormatDuration(*details.retry_delay) + ")"));
  EXPECT_EQ(client::ExitCodeFor(refused.status()), client::kExitRetryLater);

  held_context.TryCancel();
  held->Finish();
}

TEST(CallError, JobTooLargeSaysFixTheInputWithoutARetry) {
  server::ServerOptions options;
  options.limits.max_points_per_job = 50;
  InProcessServer server(options);
  const auto refused = server.Client().Process(SimpleHeader(), Line(100));
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  EXPECT_EQ(client::DetailsOf(refused.status()).reason, "JOB_TOO_LARGE");
  EXPECT_FALSE(client::DetailsOf(refused.status()).retry_delay.has_value());
  EXPECT_THAT(client::Describe(refused.status()), HasSubstr("(reason JOB_TOO_LARGE)"));
  EXPECT_EQ(client::ExitCodeFor(refused.status()), client::kExitFixInput);
}

TEST(CallError, InvalidArgumentSaysFixTheInput) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader();
  header.mutable_options()->add_stages("sharpen");
  const auto refused = server.Client().Process(header, Line(100));
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument) << refused.status();
  EXPECT_EQ(client::ExitCodeFor(refused.status()), client::kExitFixInput);
}

TEST(CallError, UnreachableServerSaysRetryLater) {
  auto client = client::ScanPrepClient::Connect("127.0.0.1:1");
  const auto refused = client.Process(SimpleHeader(), Line(10), {.timeout = absl::Seconds(5)});
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kUnavailable) << refused.status();
  EXPECT_THAT(client::Describe(refused.status()), Not(HasSubstr("reason")));
  EXPECT_EQ(client::ExitCodeFor(refused.status()), client::kExitRetryLater);
}

TEST(CallError, ACorruptedTransferSaysRetryLater) {
  // A checksum or count mismatch, on the upload (the server's) or the result (the client's).
  EXPECT_EQ(client::ExitCodeFor(absl::DataLossError("bad chunk")), client::kExitRetryLater);
}

TEST(CallError, OtherFailuresAreGeneric) {
  EXPECT_EQ(client::ExitCodeFor(absl::CancelledError("cancelled")), client::kExitFailure);
  EXPECT_EQ(client::Describe(absl::DataLossError("bad chunk")), "DATA_LOSS: bad chunk");
}

}  // namespace
}  // namespace scanprep::testing
