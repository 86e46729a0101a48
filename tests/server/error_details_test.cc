// SPDX-License-Identifier: Apache-2.0
// The standard error details a client program acts on: every RESOURCE_EXHAUSTED carries a
// google.rpc.ErrorInfo with a stable reason, and a google.rpc.RetryInfo exactly when the same call
// can succeed later; every INVALID_ARGUMENT a reason and a google.rpc.BadRequest naming the field.
// Parsed here from the grpc-status-details-bin trailer, independently of the client's code.
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

struct Details {
  std::string reason;
  std::string domain;
  std::optional<absl::Duration> retry_delay;
  std::vector<std::string> fields;              // BadRequest field violations
  std::map<std::string, std::string> metadata;  // ErrorInfo's
};

std::optional<Details> Parse(const grpc::Status& status) {
  google::rpc::Status rpc;
  if (status.error_details().empty() || !rpc.ParseFromString(status.error_details())) {
    return std::nullopt;
  }
  EXPECT_EQ(rpc.code(), status.error_code());
  EXPECT_EQ(rpc.message(), status.error_message());
  Details d;
  for (const google::protobuf::Any& any : rpc.details()) {
    google::rpc::ErrorInfo info;
    google::rpc::RetryInfo retry;
    google::rpc::BadRequest bad_request;
    if (any.UnpackTo(&bad_request)) {
      for (const auto& violation : bad_request.field_violations()) {
        d.fields.push_back(violation.field());
        EXPECT_EQ(violation.description(), status.error_message());
      }
    } else if (any.UnpackTo(&info)) {
      d.reason = info.reason();
      d.domain = info.domain();
      d.metadata.insert(info.metadata().begin(), info.metadata().end());
    } else if (any.UnpackTo(&retry)) {
      d.retry_delay = absl::Seconds(retry.retry_delay().seconds()) +
                      absl::Nanoseconds(retry.retry_delay().nanos());
    }
  }
  return d;
}

grpc::Status SmallJob(v1::ScanPrep::Stub& stub) {
  return RawCall(stub, {HeaderRequest(SimpleHeader()), ChunkRequest(LineChunk(100))});
}

TEST(ErrorDetails, QueueFullIsRetryable) {
  InProcessServer server(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 0});
  auto stub = server.Stub();
  HeldCall held(*stub);
  const grpc::Status refused = SmallJob(*stub);
  ASSERT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  const auto d = Parse(refused);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->reason, "QUEUE_FULL");
  EXPECT_EQ(d->domain, "scanprep.v1");
  ASSERT_TRUE(d->retry_delay.has_value());
  EXPECT_GE(*d->retry_delay, absl::Seconds(1));
}

// options.fail_on: the warning's code is the reason, its text and numbers the metadata. The
// upload's POINTS_INVALID fails the job before any stage runs; the control fails on another code.
TEST(ErrorDetails, AJobFailedOnAWarningNamesItsCodeAndNumbers) {
  InProcessServer server;
  auto stub = server.Stub();
  v1::PointChunk chunk = LineChunk(100);
  chunk.set_xyz(4, std::numeric_limits<float>::quiet_NaN());  // point 1's y
  for (const auto& [fail_on, fails] : {std::pair{v1::WARNING_CODE_POINTS_INVALID, true},
                                       std::pair{v1::WARNING_CODE_UNIT_SUSPECT, false}}) {
    v1::JobHeader header = SimpleHeader();
    header.mutable_options()->add_fail_on(fail_on);
    const grpc::Status status = RawCall(*stub, {HeaderRequest(header), ChunkRequest(chunk)});
    if (!fails) {
      EXPECT_TRUE(status.ok()) << status.error_message();
      continue;
    }
    ASSERT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    const auto d = Parse(status);
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(d->reason, "POINTS_INVALID");
    EXPECT_EQ(d->domain, "scanprep.v1");
    EXPECT_FALSE(d->retry_delay.has_value());
    EXPECT_EQ(d->metadata.at("points_invalid"), "1");
    EXPECT_EQ(d->metadata.at("points_received"), "100");
    EXPECT_THAT(d->metadata.at("message"),
                ::testing::HasSubstr("1 of 100 points were excluded: 1 with NaN"));
  }
}

TEST(ErrorDetails, PerHostLimitIsRetryable) {
  InProcessServer server(server::ServerOptions{.max_calls_per_peer = 1});
  auto stub = server.Stub();
  HeldCall held(*stub);
  const auto d = Parse(SmallJob(*stub));
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->reason, "PEER_LIMIT");
  EXPECT_EQ(d->retry_delay, absl::Seconds(1));
}

TEST(ErrorDetails, JobsTooLargeAreNeverRetryable) {
  server::ServerOptions options;
  options.limits.max_points_per_job = 1000;
  options.limits.max_scans_per_job = 1;
  options.limits.max_chunk_points = 50;
  InProcessServer server(options);
  auto stub = server.Stub();

  v1::JobHeader too_many_points = SimpleHeader();
  too_many_points.set_total_points(5000);
  v1::JobHeader two_scans = SimpleHeader();
  two_scans.add_scans()->set_scan_id("second");
  const std::pair<std::string, grpc::Status> cases[] = {
      {"JOB_TOO_LARGE", RawCall(*stub, {HeaderRequest(too_many_points)})},
      {"TOO_MANY_SCANS", RawCall(*stub, {HeaderRequest(two_scans)})},
      {"CHUNK_TOO_LARGE", SmallJob(*stub)},
  };
  for (const auto& [reason, status] : cases) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << reason;
    const auto d = Parse(status);
    ASSERT_TRUE(d.has_value()) << reason;
    EXPECT_EQ(d->reason, reason);
    EXPECT_FALSE(d->retry_delay.has_value()) << reason;
  }

  server::ServerOptions small_calls;
  small_calls.limits.max_bytes_per_call = 100;
  InProcessServer bytes(small_calls);
  const auto d = Parse(SmallJob(*bytes.Stub()));
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->reason, "CALL_TOO_LARGE");
  EXPECT_FALSE(d->retry_delay.has_value());
}

// A plan whose parameters multiply its work past --max_plan_cost is refused at its header, with
// the estimate and the limit as numbers; one costly parameter alone is admitted.
TEST(ErrorDetails, CostlyPlansAreRefusedAtTheHeaderWithTheirCost) {
  InProcessServer server;
  auto stub = server.Stub();
  v1::JobHeader costly = SimpleHeader();
  auto& params = *costly.mutable_options()->mutable_params();
  params["smoothing.iterations"] = "7";
  params["neighbourhoods.min_radius_mm"] = "10000";
  const grpc::Status status = RawCall(*stub, {HeaderRequest(costly)});
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(),
              ::testing::AllOf(::testing::HasSubstr("smoothing.iterations=7"),
                               ::testing::HasSubstr("neighbourhoods.min_radius_mm=10000")));
  const auto d = Parse(status);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->reason, "JOB_TOO_COSTLY");
  EXPECT_FALSE(d->retry_delay.has_value());
  EXPECT_EQ(d->metadata.at("max_plan_cost"), "3");
  EXPECT_GT(std::stod(d->metadata.at("estimated_cost")), 3);

  params.erase("neighbourhoods.min_radius_mm");
  EXPECT_NE(Parse(RawCall(*stub, {HeaderRequest(costly)})).value_or(Details{}).reason,
            "JOB_TOO_COSTLY");
}

// Each invalid input names its field as a path in the request: the header's fields by name, the
// PointChunk messages by their index in the upload.
TEST(ErrorDetails, InvalidInputNamesTheFieldAtFault) {
  InProcessServer server;
  auto stub = server.Stub();
  struct Case {
    std::string reason;
    std::string field;
    std::vector<v1::ProcessRequest> requests;
  };
  std::vector<Case> cases;
  {
    v1::JobHeader header = SimpleHeader();
    header.add_scans()->set_scanline_spacing(1e300);
    cases.push_back(
        {"INVALID_METADATA", "header.scans[1].scanline_spacing", {HeaderRequest(header, 10)}});
  }
  {
    v1::JobHeader header = SimpleHeader();
    header.mutable_scans(0)->set_sensor_id("cell 3");  // a space: not a label value
    cases.push_back({"INVALID_METADATA", "header.scans[0].sensor_id", {HeaderRequest(header, 10)}});
  }
  {
    v1::JobHeader header = SimpleHeader();
    (*header.mutable_options()->mutable_params())["smoothing.lambda"] = "1.5";
    cases.push_back({"INVALID_PARAMETER",
                     "header.options.params['smoothing.lambda']",
                     {HeaderRequest(header, 10)}});
  }
  {
    v1::JobHeader header = SimpleHeader();
    header.mutable_options()->add_stages("sharpen");
    cases.push_back({"INVALID_PARAMETER", "header.options.stages", {HeaderRequest(header, 10)}});
  }
  {
    v1::JobHeader header = SimpleHeader();
    (*header.mutable_budget()->mutable_stage_seconds())["outliers"] = -1;
    cases.push_back({"INVALID_PARAMETER",
                     "header.budget.stage_seconds['outliers']",
                     {HeaderRequest(header, 10)}});
  }
  {
    v1::JobHeader header = SimpleHeader();
    header.clear_unit();
    cases.push_back({"INVALID_HEADER", "header.unit", {HeaderRequest(header, 10)}});
  }
  cases.push_back({"INVALID_HEADER", "header", {ChunkRequest(LineChunk(10))}});
  {
    v1::PointChunk ragged = LineChunk(1);
    ragged.add_xyz(1.f);
    cases.push_back(
        {"INVALID_CHUNK",
         "points[1].xyz",
         {HeaderRequest(SimpleHeader(), 20), ChunkRequest(LineChunk(10)), ChunkRequest(ragged)}});
  }
  {
    v1::PointChunk chunk = LineChunk(10);
    for (int i = 0; i < 10; ++i) chunk.add_quality(i == 3 ? 2.f : 0.5f);
    cases.push_back({"INVALID_CHUNK",
                     "points[0].quality[3]",
                     {HeaderRequest(SimpleHeader(), 10), ChunkRequest(chunk)}});
  }
  {
    v1::PointChunk nan = LineChunk(10);
    for (int i = 0; i < nan.xyz_size(); ++i) nan.set_xyz(i, std::nanf(""));
    cases.push_back(
        {"INVALID_CHUNK", "points", {HeaderRequest(SimpleHeader(), 10), ChunkRequest(nan)}});
  }
  std::vector<v1::ProcessRequest> miscounted = {HeaderRequest(SimpleHeader(), 30),
                                                ChunkRequest(LineChunk(30))};
  miscounted.push_back(EndRequest(miscounted));
  miscounted.back().mutable_end()->set_points(20);
  cases.push_back({"POINT_COUNT_MISMATCH", "end.points", miscounted});

  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    const grpc::Status status = RawCall(*stub, c.requests);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    const auto d = Parse(status);
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(d->reason, c.reason);
    EXPECT_FALSE(d->retry_delay.has_value());
    EXPECT_EQ(d->fields, std::vector<std::string>{c.field});
  }
}

}  // namespace
}  // namespace scanprep::testing
