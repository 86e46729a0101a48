// SPDX-License-Identifier: Apache-2.0
// `scanprep load`: the real CLI binary against an in-process server for about two seconds; its
// JSON must describe what happened (jobs, errors by code, consistent throughput and latency).
#include <gmock/gmock.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <sstream>

#include "client/call_error.h"
#include "client/latency_stats.h"
#include "client/load_generator.h"
#include "core/io/ply.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/run_command.h"
#include "wire/error_details.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(LatencyStats, NearestRankPercentilesOfOneToHundred) {
  std::vector<double> samples;
  for (int i = 1; i <= 100; ++i) samples.push_back(i);
  std::shuffle(samples.begin(), samples.end(), std::mt19937(3));
  const client::LatencySummary s = client::Summarize(samples);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.mean, 50.5);
  EXPECT_EQ(s.p50, 50);
  EXPECT_EQ(s.p90, 90);
  EXPECT_EQ(s.p99, 99);
  EXPECT_EQ(s.max, 100);
}

TEST(LatencyStats, FewSamplesPickObservedValues) {
  const client::LatencySummary s = client::Summarize({0.3, 0.1, 0.2});
  EXPECT_EQ(s.p50, 0.2);  // rank ceil(1.5) = 2
  EXPECT_EQ(s.p90, 0.3);
  EXPECT_EQ(s.p99, 0.3);
  EXPECT_EQ(client::Summarize({}).count, 0u);
}

struct LoadRun {
  CommandResult command;
  google::protobuf::Struct json;
  double Number(const std::string& key) const { return json.fields().at(key).number_value(); }
  double Latency(const std::string& key) const {
    return json.fields().at("latency_s").struct_value().fields().at(key).number_value();
  }
};

class LoadCommand : public ::testing::Test {
 protected:
  // A 60×60 noisy plane (about 3,600 points) as a PLY file, written once.
  static void SetUpTestSuite() {
    scan_ = new fs::path(fs::path(::testing::TempDir()) /
                         ("load_plane_" + std::to_string(getpid()) + ".ply"));
    const PointCloud plane = NoisyPlaneWithSpikes(60, 0.5f).cloud;
    points_ = plane.size();
    ASSERT_TRUE(io::WritePly(*scan_, plane).ok());
  }
  static void TearDownTestSuite() {
    fs::remove(*scan_);
    delete scan_;
  }

  // `input`: the job's source; by default the plane file.
  static LoadRun Load(const std::string& target, const std::string& flags,
                      const std::string& input = "") {
    // Per process: ctest runs this file's tests in parallel processes, and one removing or
    // writing another's file made its JSON empty.
    const fs::path json =
        fs::path(::testing::TempDir()) / ("load_" + std::to_string(getpid()) + ".json");
    fs::remove(json);
    LoadRun run;
    run.command = RunCommand(std::string(SCANPREP_CLI_BINARY) + " load --server " + target +
                             " --json " + json.string() + " " + flags + " " +
                             (input.empty() ? "--scanline_spacing 0.5 " + scan_->string() : input));
    std::ifstream in(json);
    std::stringstream text;
    text << in.rdbuf();
    const auto status = google::protobuf::util::JsonStringToMessage(text.str(), &run.json);
    EXPECT_TRUE(status.ok()) << status.ToString() << "\n" << run.command.output;
    return run;
  }

  static fs::path* scan_;
  static size_t points_;
};

fs::path* LoadCommand::scan_ = nullptr;
size_t LoadCommand::points_ = 0;

TEST_F(LoadCommand, ClosedLoopReportsConsistentNumbers) {
  InProcessServer server;
  const LoadRun run = Load(server.target(), "--concurrency 2 --duration 2s");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_THAT(run.command.output, HasSubstr("PASS"));
  EXPECT_EQ(run.json.fields().at("mode").string_value(), "closed");
  EXPECT_EQ(run.Number("points_per_job"), points_);
  const double jobs = run.Number("jobs");
  EXPECT_GT(jobs, 0);
  EXPECT_EQ(run.Number("errors"), 0);
  EXPECT_EQ(run.json.fields().at("errors_by_code").struct_value().fields_size(), 0);
  EXPECT_LE(run.Latency("p50"), run.Latency("p90"));
  EXPECT_LE(run.Latency("p90"), run.Latency("p99"));
  EXPECT_LE(run.Latency("p99"), run.Latency("max"));
  EXPECT_GT(run.Latency("p50"), 0);
  // No call starts after 2 s; the last ones end soon after.
  const double elapsed = run.Number("elapsed_s");
  EXPECT_GE(elapsed, 2.0);
  EXPECT_NEAR(run.Number("jobs_per_s"), jobs / elapsed, 1e-3 * jobs / elapsed);
  EXPECT_NEAR(run.Number("points_per_s"), jobs * points_ / elapsed,
              1e-3 * jobs * points_ / elapsed);
  // Two workers never have more than two calls in flight: the call times fit twice the run.
  EXPECT_LE(jobs * run.Latency("mean"), 2 * elapsed);
  EXPECT_TRUE(run.json.fields().at("passed").bool_value());
}

// One slot, one queue place, calls one after another: had an aborted upload kept its slot or
// queue place, every later call would wait until its 5 s deadline and fail.
TEST_F(LoadCommand, AbortedUploadsLeaveNoSlotBehind) {
  InProcessServer server(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 1});
  const LoadRun run = Load(server.target(),
                           "--concurrency 1 --max_jobs 40 --abort_uploads 0.5 --chunk_points 500 "
                           "--timeout 5s");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_EQ(run.Number("aborted_uploads"), 20) << run.command.output;
  EXPECT_EQ(run.Number("jobs"), 20);
  EXPECT_EQ(run.Number("errors"), 0);
  EXPECT_THAT(run.command.output, HasSubstr("aborted uploads: 20"));
}

// With --retry=false every refusal is an error, RetryInfo or not.
TEST_F(LoadCommand, RejectedCallsAreCountedByCodeAndFailTheRun) {
  InProcessServer server(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 0});
  const LoadRun run = Load(server.target(), "--concurrency 4 --duration 2s --retry=false");
  EXPECT_EQ(run.command.exit_code, 1) << run.command.output;
  const double rejected = run.Number("resource_exhausted");
  EXPECT_GT(rejected, 0) << run.command.output;
  EXPECT_EQ(run.json.fields()
                .at("errors_by_code")
                .struct_value()
                .fields()
                .at("RESOURCE_EXHAUSTED")
                .number_value(),
            rejected);
  EXPECT_EQ(run.Number("errors"), rejected);
  EXPECT_GT(run.Number("jobs"), 0);  // the one admitted call at a time still succeeds
  EXPECT_FALSE(run.json.fields().at("passed").bool_value());
  EXPECT_THAT(run.command.output, HasSubstr("max_concurrent_jobs"));
  EXPECT_EQ(run.Number("retried_refusals"), 0);
}

// By default a QUEUE_FULL refusal (one slot, no queue, three workers) is waited out for its
// RetryInfo delay (at least 1 s) and sent again: every job runs, none is an error.
TEST_F(LoadCommand, RefusalsWithRetryInfoAreSentAgainAfterTheirDelay) {
  InProcessServer server(server::ServerOptions{.max_concurrent_jobs = 1, .max_queued_jobs = 0});
  const LoadRun run = Load(server.target(), "--concurrency 3 --max_jobs 6 --duration 60s");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_EQ(run.Number("jobs"), 6);
  EXPECT_EQ(run.Number("errors"), 0);
  EXPECT_GT(run.Number("retried_refusals"), 0) << run.command.output;
  EXPECT_THAT(run.command.output, HasSubstr("retried refusals: "));
  // A retried call waited at least the 1 s the server asked for, inside its latency.
  EXPECT_GE(run.Latency("max"), 1.0);
}

// The acceptance run, shortened: the real server with its default flags on the shipped
// pod's 2 slots, four workers on one host. Each worker's call holds a slot or waits in the queue;
// before, the host's second call was refused (PEER_LIMIT) and the run failed with hundreds of
// errors.
TEST_F(LoadCommand, OneHostsFourWorkersOnATwoSlotServerRunWithoutErrors) {
  ServerProcess server({"--max_concurrent_jobs=2"});
  ASSERT_GT(server.port(), 0);
  const LoadRun run = Load(server.target(), "--concurrency 4 --duration 3s");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_GT(run.Number("jobs"), 0);
  EXPECT_EQ(run.Number("errors"), 0) << run.command.output;
  EXPECT_EQ(run.Number("retried_refusals"), 0) << run.command.output;  // nothing was refused
}

// What RetryInfo makes a worker wait: the server's own refusals, encoded as they travel.
TEST(RetryWait, TheServersDelayCappedAndJitteredOnRetryableCodesOnly) {
  const auto sent = [](absl::Status status, std::string_view reason,
                       std::optional<absl::Duration> retry) {
    return client::FromGrpc(ToGrpc(WithReason(std::move(status), reason, retry)));
  };
  const absl::Status queue_full =
      sent(absl::ResourceExhaustedError("full"), "QUEUE_FULL", absl::Seconds(2));
  EXPECT_EQ(client::RetryWait(queue_full, 0), absl::Seconds(2));
  EXPECT_EQ(client::RetryWait(queue_full, 0.5), absl::Seconds(2.25));  // up to a quarter more
  EXPECT_EQ(client::RetryWait(
                sent(absl::UnavailableError("draining"), "SHUTTING_DOWN", absl::Seconds(1)), 0),
            absl::Seconds(1));
  EXPECT_EQ(client::RetryWait(
                sent(absl::ResourceExhaustedError("full"), "QUEUE_FULL", absl::Minutes(5)), 0),
            client::kMaxRetryWait);
  EXPECT_EQ(client::RetryWait(
                sent(absl::ResourceExhaustedError("full"), "QUEUE_FULL", absl::ZeroDuration()), 0),
            client::kPauseAfterError);
  // Never again: too large (no RetryInfo), a corrupted transfer (DATA_LOSS, the client library's
  // business), an UNAVAILABLE without RetryInfo (a lost connection the client library retried).
  EXPECT_EQ(client::RetryWait(
                sent(absl::ResourceExhaustedError("big"), "JOB_TOO_LARGE", std::nullopt), 0),
            std::nullopt);
  EXPECT_EQ(client::RetryWait(
                sent(absl::DataLossError("crc"), "CHECKSUM_MISMATCH", absl::ZeroDuration()), 0),
            std::nullopt);
  EXPECT_EQ(client::RetryWait(absl::UnavailableError("connection reset"), 0), std::nullopt);
}

TEST_F(LoadCommand, OpenLoopStopsAfterMaxJobs) {
  InProcessServer server;
  const LoadRun run = Load(
      server.target(), "--concurrency 2 --rate 20 --arrivals fixed --max_jobs 6 --duration 10s");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_EQ(run.json.fields().at("mode").string_value(), "fixed");
  EXPECT_EQ(run.Number("jobs"), 6);
  // Six arrivals 50 ms apart: the sixth starts at 0.25 s, long before the 10 s limit.
  EXPECT_GE(run.Number("elapsed_s"), 0.25);
  EXPECT_LT(run.Number("elapsed_s"), 10);
}

TEST_F(LoadCommand, LatencyAboveTheBudgetFailsTheRun) {
  InProcessServer server;
  const LoadRun run = Load(server.target(), "--concurrency 1 --max_jobs 3 --budget 0.000001");
  EXPECT_EQ(run.command.exit_code, 1) << run.command.output;
  EXPECT_EQ(run.Number("jobs"), 3);
  EXPECT_EQ(run.Number("errors"), 0);
  EXPECT_EQ(run.Number("budget_s"), 1e-6);
  // The budget travels in the job header, so the server's reports miss it too.
  EXPECT_EQ(run.Number("budget_misses"), 3);
  EXPECT_THAT(run.command.output, HasSubstr("exceeds the budget of 1e-06 s"));
}

TEST_F(LoadCommand, ReplaysAGeneratedScan) {
  InProcessServer server;
  const LoadRun run = Load(server.target(), "--max_jobs 2", "--simulate 3000 --part sphere");
  ASSERT_EQ(run.command.exit_code, 0) << run.command.output;
  EXPECT_EQ(run.Number("jobs"), 2);
  EXPECT_EQ(run.Number("scans_per_job"), 1);
  EXPECT_NEAR(run.Number("points_per_job"), 3000, 0.02 * 3000);
  // Generated scans are millimetres and posed already: file options contradict them.
  const CommandResult r = RunCommand(std::string(SCANPREP_CLI_BINARY) + " load --server " +
                                     server.target() + " --simulate 3000 --unit m");
  EXPECT_EQ(r.exit_code, 2);  // a usage error
  EXPECT_THAT(r.output, HasSubstr("--unit does not apply to a generated scan"));
}

// Two replicas behind one address list; one is killed (SIGKILL) while calls run on it. Its calls
// end UNAVAILABLE and are sent again to the live one: no job is lost, and the retries are counted.
TEST_F(LoadCommand, AKilledReplicaLosesNoJob) {
  ServerProcess doomed, survivor;
  ASSERT_GT(doomed.port(), 0);
  ASSERT_GT(survivor.port(), 0);
  auto run = std::async(std::launch::async, [&] {
    return Load(doomed.target() + "," + survivor.target(),
                "--concurrency 4 --duration 4s --timeout 60s", "--simulate 40000");
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(doomed.pid(), SIGKILL);
  const LoadRun result = run.get();
  ASSERT_EQ(result.command.exit_code, 0) << result.command.output;
  EXPECT_EQ(result.Number("errors"), 0) << result.command.output;
  EXPECT_GT(result.Number("jobs"), 0);
  EXPECT_GE(result.Number("retries"), 1) << result.command.output;
  EXPECT_THAT(result.command.output, HasSubstr("retries: "));
}

TEST(LoadTargets, ListsOfAddressesBecomeAnIpv4Target) {
  EXPECT_EQ(*client::ChannelTarget("127.0.0.1:5001"), "127.0.0.1:5001");
  EXPECT_EQ(*client::ChannelTarget("dns:///scanprep:50051"), "dns:///scanprep:50051");
  EXPECT_EQ(*client::ChannelTarget("10.0.0.1:1,10.0.0.2:2"), "ipv4:10.0.0.1:1,10.0.0.2:2");
  const auto named = client::ChannelTarget("10.0.0.1:1,scanprep:2");
  ASSERT_FALSE(named.ok());
  EXPECT_THAT(named.status().message(), HasSubstr("'scanprep:2' in a list is not an IPv4"));
}

// `simulate` writes one PLY per scan and a job file whose scan ids are the files' stems, so
// `process` finds every scan's metadata.
TEST(SimulateCommand, WritesScansAndTheirJobFile) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("simulate_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const CommandResult r =
      RunCommand(std::string(SCANPREP_CLI_BINARY) + " simulate --points 6000 " +
                 "--part box --scans 2 --seed 5 -o " + (dir / "sim.ply").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::vector<std::string> ply_warnings;
  auto frontal = io::ReadPly(dir / "sim_frontal.ply", ply_warnings);
  auto oblique = io::ReadPly(dir / "sim_oblique.ply", ply_warnings);
  ASSERT_TRUE(frontal.ok()) << frontal.status();
  ASSERT_TRUE(oblique.ok()) << oblique.status();
  EXPECT_NEAR(double(frontal->size() + oblique->size()), 6000, 0.02 * 6000);
  EXPECT_TRUE(frontal->has_scanlines());
  EXPECT_THAT(r.output, HasSubstr("--job " + (dir / "sim.job.json").string()));

  std::ifstream in(dir / "sim.job.json");
  std::stringstream text;
  text << in.rdbuf();
  v1::JobHeader header;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(text.str(), &header).ok()) << text.str();
  EXPECT_EQ(header.unit(), v1::LENGTH_UNIT_MILLIMETRE);
  ASSERT_EQ(header.scans_size(), 2);
  EXPECT_EQ(header.scans(0).scan_id(), "sim_frontal");
  EXPECT_EQ(header.scans(1).scan_id(), "sim_oblique");
  for (const v1::ScanHeader& scan : header.scans()) {
    EXPECT_GT(scan.scanline_spacing(), 0);
    EXPECT_GT(scan.point_spacing(), 0);
    EXPECT_TRUE(scan.has_camera_position());
    EXPECT_TRUE(scan.has_projector_direction());
  }
  // The oblique sensor is the noisier one.
  EXPECT_DOUBLE_EQ(header.scans(1).uncertainty(), 2 * header.scans(0).uncertainty());
  fs::remove_all(dir);
}

TEST_F(LoadCommand, UnreachableServerFailsAtOnce) {
  const CommandResult r =
      RunCommand(std::string(SCANPREP_CLI_BINARY) + " load --server 127.0.0.1:1 --duration 60s " +
                 scan_->string());
  EXPECT_EQ(r.exit_code, 3);  // "retry later"
  EXPECT_THAT(r.output, HasSubstr("UNAVAILABLE"));
}

TEST_F(LoadCommand, BadFlagsAreNamed) {
  CommandResult r = RunCommand(std::string(SCANPREP_CLI_BINARY) +
                               " load --server 127.0.0.1:1 --concurrency 0 " + scan_->string());
  EXPECT_EQ(r.exit_code, 2);  // a usage error
  EXPECT_THAT(r.output, HasSubstr("--concurrency"));
  r = RunCommand(std::string(SCANPREP_CLI_BINARY) + " load --server 127.0.0.1:1 --duration soon " +
                 scan_->string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("--duration: 'soon' is not a positive duration"));
}

}  // namespace
}  // namespace scanprep::testing
