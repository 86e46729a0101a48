// SPDX-License-Identifier: Apache-2.0
// What the client makes of a failed call: the server's ErrorInfo reason and RetryInfo delay reach
// the absl::Status, and the exit code says "retry later" exactly when a retry can succeed and "fix
// the input" when the job itself was refused.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

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
  HeldCall held(*stub);  // holds the only slot
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

// Issue 40: a --timeout overrun exited 1, the code of a local failure; now its own code.
TEST(CallError, ADeadlinePassedSaysTimedOut) {
  EXPECT_EQ(client::ExitCodeFor(absl::DeadlineExceededError("the call's deadline passed")),
            client::kExitTimedOut);
}

TEST(CallError, OtherFailuresAreGeneric) {
  EXPECT_EQ(client::ExitCodeFor(absl::CancelledError("cancelled")), client::kExitFailure);
  EXPECT_EQ(client::Describe(absl::DataLossError("bad chunk")), "DATA_LOSS: bad chunk");
}

TEST(CallError, AFieldViolationIsPrintedWithItsPath) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader();
  (*header.mutable_options()->mutable_params())["smoothing.lambda"] = "1.5";
  const auto refused = server.Client().Process(header, Line(100));
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument) << refused.status();
  EXPECT_EQ(client::Describe(refused.status()),
            "INVALID_ARGUMENT: options.params['smoothing.lambda']: 1.5 is outside [0, 1] (reason "
            "INVALID_PARAMETER; field header.options.params['smoothing.lambda'])");
}

// A job failed on a warning it named (options.fail_on): the reason is the warning's code, a
// name from core's list (so not among the server's literals below), and the input is at fault.
TEST(CallError, AJobFailedOnAWarningMeansFixTheInput) {
  InProcessServer server;
  v1::JobHeader header = SimpleHeader();
  header.mutable_options()->add_fail_on(v1::WARNING_CODE_POINTS_INVALID);
  v1::PointChunk chunk = LineChunk(10);
  chunk.set_xyz(0, std::numeric_limits<float>::infinity());
  const absl::Status status =
      client::FromGrpc(RawCall(*server.Stub(), {HeaderRequest(header, 10), ChunkRequest(chunk)}));
  ASSERT_EQ(status.code(), absl::StatusCode::kFailedPrecondition) << status;
  EXPECT_EQ(client::DetailsOf(status).reason, "POINTS_INVALID");
  EXPECT_FALSE(client::DetailsOf(status).retry_delay.has_value());
  EXPECT_EQ(client::ExitCodeFor(status), client::kExitFixInput);
  EXPECT_THAT(client::Describe(status), HasSubstr("(reason POINTS_INVALID)"));
}

// The reasons the server can send: every UPPER_SNAKE_CASE string literal in server/ and in the
// conversion it links (wire/) that is not a gRPC code's name (they are tagged where they
// arise, with WithReason or WithFieldViolation).
std::set<std::string> ReasonsInServerSources() {
  std::set<std::string> codes;
  for (int c = 0; c <= 16; ++c) {
    codes.insert(absl::StatusCodeToString(static_cast<absl::StatusCode>(c)));
  }
  const std::regex literal("\"([A-Z][A-Z0-9]*(_[A-Z0-9]+)+)\"");
  std::set<std::string> reasons;
  for (const char* dir : {SCANPREP_SERVER_SOURCES, SCANPREP_CONVERT_SOURCES}) {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
      if (!entry.is_regular_file()) continue;
      std::ifstream in(entry.path());
      const std::string text((std::istreambuf_iterator<char>(in)), {});
      for (std::sregex_iterator m(text.begin(), text.end(), literal), end; m != end; ++m) {
        if (!codes.contains((*m)[1])) reasons.insert((*m)[1]);
      }
    }
  }
  return reasons;
}

// Every reason the server sends, provoked against the real service and parsed by the client's
// own code: the reason, a RetryInfo exactly when a retry can succeed, a field violation exactly
// for INVALID_ARGUMENT, and the exit code that follows.
TEST(CallError, EveryReasonIsParsedByTheClient) {
  // A server whose resident memory (a test source, sampled first at 1 GiB while idle) jumps by
  // 1 TiB once a job is processing: the memory guard ends the job. The job's first progress event
  // holds it until the guard has had many samples to see it.
  constexpr uint64_t kIdle = uint64_t{1} << 30, kBlownUp = uint64_t{1} << 40;
  std::atomic<uint64_t> resident{kIdle};
  server::ServerOptions guarded_options;
  guarded_options.memory_guard.enabled = true;
  guarded_options.memory_guard.resident_bytes = [&resident]() -> std::optional<uint64_t> {
    return resident.load();
  };
  guarded_options.on_progress = [&resident](std::string_view, double) {
    if (resident.exchange(kBlownUp) == kIdle)
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
  };
  InProcessServer guarded(guarded_options);
  InProcessServer busy(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 0});
  InProcessServer per_host(server::ServerOptions{.max_calls_per_peer = 1});
  server::ServerOptions small;
  small.limits.max_points_per_job = 1000;
  small.limits.max_scans_per_job = 1;
  small.limits.max_chunk_points = 50;
  small.limits.max_bytes_per_call = 2000;
  InProcessServer limited(small);
  InProcessServer tight_memory(server::ServerOptions{.memory_capacity_bytes = 64 << 20});
  InProcessServer draining;
  draining.server().Drain();
  auto busy_stub = busy.Stub();
  auto per_host_stub = per_host.Stub();
  auto stub = limited.Stub();
  HeldCall held_slot(*busy_stub);
  HeldCall held_place(*per_host_stub);

  const std::vector<v1::ProcessRequest> small_job = {HeaderRequest(SimpleHeader(), 10),
                                                     ChunkRequest(LineChunk(10))};
  v1::JobHeader two_scans = SimpleHeader();
  two_scans.add_scans()->set_scan_id("second");
  v1::JobHeader far_camera = SimpleHeader();
  far_camera.mutable_scans(0)->mutable_camera_position()->set_x(1e300);
  v1::JobHeader bad_param = SimpleHeader();
  (*bad_param.mutable_options()->mutable_params())["outliers.k"] = "0";
  v1::JobHeader no_unit = SimpleHeader();
  no_unit.clear_unit();
  v1::JobHeader costly = SimpleHeader();
  (*costly.mutable_options()->mutable_params())["smoothing.iterations"] = "7";
  (*costly.mutable_options()->mutable_params())["neighbourhoods.k"] = "64";
  std::vector<v1::ProcessRequest> miscounted = small_job, corrupted = small_job;
  miscounted.push_back(EndRequest(small_job));
  miscounted.back().mutable_end()->set_points(9);
  corrupted.push_back(EndRequest(small_job));
  corrupted.back().mutable_end()->set_crc32(corrupted.back().end().crc32() ^ 1);
  std::vector<v1::ProcessRequest> call_too_large = {HeaderRequest(SimpleHeader(), 200)};
  for (int i = 0; i < 5; ++i) call_too_large.push_back(ChunkRequest(LineChunk(40)));

  struct Case {
    std::string reason;
    grpc::Status status;
    std::string field;  // the violation's, for INVALID_ARGUMENT
  };
  const Case cases[] = {
      {"QUEUE_FULL", RawCall(*busy_stub, small_job), ""},
      {"PEER_LIMIT", RawCall(*per_host_stub, small_job), ""},
      {"JOB_TOO_LARGE", RawCall(*stub, {HeaderRequest(SimpleHeader(), 5000)}), ""},
      {"SHUTTING_DOWN", RawCall(*draining.Stub(), small_job), ""},
      {"JOB_EXCEEDS_MEMORY",
       RawCall(*tight_memory.Stub(), {HeaderRequest(SimpleHeader(), 200'000)}), ""},
      {"MEMORY_RESERVATION_EXCEEDED", RawCall(*guarded.Stub(), small_job), ""},
      {"TOO_MANY_SCANS", RawCall(*stub, {HeaderRequest(two_scans, 10)}), ""},
      {"JOB_TOO_COSTLY", RawCall(*stub, {HeaderRequest(costly, 10)}), ""},
      {"CHUNK_TOO_LARGE",
       RawCall(*stub, {HeaderRequest(SimpleHeader(), 100), ChunkRequest(LineChunk(100))}), ""},
      {"CALL_TOO_LARGE", RawCall(*stub, call_too_large), ""},
      {"INVALID_HEADER", RawCall(*stub, {HeaderRequest(no_unit, 10)}), "header.unit"},
      {"INVALID_METADATA", RawCall(*stub, {HeaderRequest(far_camera, 10)}),
       "header.scans[0].camera_position"},
      {"INVALID_PARAMETER", RawCall(*stub, {HeaderRequest(bad_param, 10)}),
       "header.options.params['outliers.k']"},
      {"INVALID_CHUNK",
       RawCall(*stub, {HeaderRequest(SimpleHeader(), 10), ChunkRequest(LineChunk(10)),
                       ChunkRequest(LineChunk(1))}),
       "points[1].xyz"},
      {"INCOMPLETE_UPLOAD", RawCall(*stub, small_job, nullptr, Upload::kCut), "end"},
      {"POINT_COUNT_MISMATCH", RawCall(*stub, miscounted), "end.points"},
      {"CHECKSUM_MISMATCH", RawCall(*stub, corrupted), ""},
  };
  std::set<std::string> tested;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.reason);
    const absl::Status status = client::FromGrpc(c.status);
    ASSERT_FALSE(status.ok());
    const client::CallErrorDetails details = client::DetailsOf(status);
    EXPECT_EQ(details.reason, c.reason) << status;
    const bool retryable = c.reason == "QUEUE_FULL" || c.reason == "PEER_LIMIT" ||
                           c.reason == "CHECKSUM_MISMATCH" || c.reason == "SHUTTING_DOWN";
    EXPECT_EQ(details.retry_delay.has_value(), retryable);
    EXPECT_EQ(client::ExitCodeFor(status),
              retryable ? client::kExitRetryLater : client::kExitFixInput);
    if (status.code() == absl::StatusCode::kInvalidArgument) {
      ASSERT_EQ(details.field_violations.size(), 1u);
      EXPECT_EQ(details.field_violations[0].field, c.field);
      EXPECT_EQ(details.field_violations[0].description, status.message());
      EXPECT_THAT(client::Describe(status), HasSubstr("; field " + c.field + ")"));
    } else {
      const absl::StatusCode code = c.reason == "CHECKSUM_MISMATCH" ? absl::StatusCode::kDataLoss
                                    : c.reason == "SHUTTING_DOWN"
                                        ? absl::StatusCode::kUnavailable
                                        : absl::StatusCode::kResourceExhausted;
      EXPECT_EQ(status.code(), code);
      EXPECT_TRUE(details.field_violations.empty());
    }
    tested.insert(c.reason);
  }
  EXPECT_EQ(tested, ReasonsInServerSources()) << "a reason the server sends is not tested here";
}

}  // namespace
}  // namespace scanprep::testing
