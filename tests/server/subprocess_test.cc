// SPDX-License-Identifier: Apache-2.0
// The real binaries: scanprep-server as a subprocess on an ephemeral port, driven by the client
// library and by the `scanprep` CLI; graceful shutdown on SIGTERM.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "core/io/pcd.h"
#include "core/io/ply.h"
#include "core/io/scan_file.h"
#include "core/io/xyz.h"
#include "server/admission/memory_reservation.h"
#include "tests/server/metrics_scrape.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/las_file.h"
#include "tests/support/run_command.h"
#include "tests/support/test_data.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::LasFile;
using testing::LasPoint;

CommandResult RunCli(const std::string& args) {
  return RunCommand(std::string(SCANPREP_CLI_BINARY) + " " + args);
}

TEST(ServerBinary, ServesTheClientLibrary) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0) << "scanprep-server did not report its port";
  {
    // An idle client channel is only polled every few seconds, so it would hold the server's
    // shutdown until the grace period ends; the client goes away first, like the CLI does.
    auto client = client::ScanPrepClient::Connect(server.target());
    auto info = client.GetInfo(absl::Seconds(10));
    ASSERT_TRUE(info.ok()) << info.status();
    // 20 M points, or fewer when the memory capacity (half the RAM here) cannot hold such a job.
    EXPECT_GT(info->limits().memory_budget_bytes(), 0u);
    EXPECT_EQ(info->limits().max_points_per_job(),
              std::min<uint64_t>(20'000'000,
                                 server::LargestJobPoints(info->limits().memory_budget_bytes())));
    EXPECT_EQ(info->limits().max_concurrent_jobs(), 4u);
    EXPECT_EQ(info->limits().max_chunk_points(), 65'536u);
    EXPECT_EQ(info->limits().max_bytes_per_call(), 1u << 30);
    EXPECT_EQ(info->limits().max_scans_per_job(), 1'000u);
    EXPECT_EQ(info->limits().max_calls_per_peer(), 0u);  // no per-host cap

    v1::JobHeader header = SimpleHeader(0.5);
    header.mutable_options()->add_stages("outliers");
    const GeneratedScan scan = NoisyPlaneWithSpikes(100, 0.5f);
    auto result = client.Process(header, scan.cloud);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->report.points_received(), scan.cloud.size());
    EXPECT_EQ(result->report.stages(2).name(), "outliers");  // after neighbourhoods, normals
    EXPECT_EQ(result->cloud.size(), result->report.stages(2).points_out());
    EXPECT_LT(result->cloud.size(), scan.cloud.size());
  }
  EXPECT_EQ(server.Terminate(), 0);
}

TEST(ServerBinary, ServesMetricsWithTheBudgetAndQueueFlags) {
  const fs::path config = fs::path(::testing::TempDir()) / "budgets.conf";
  std::ofstream(config) << "total 12  # seconds per job\noutliers 0.5\n";
  ServerProcess server(
      {"--budget_config=" + config.string(), "--stage_budgets=smoothing=2", "--max_queued_jobs=3"});
  ASSERT_GT(server.metrics_port(), 0) << "scanprep-server did not report its metrics port";
  {
    auto info = client::ScanPrepClient::Connect(server.target()).GetInfo(absl::Seconds(10));
    ASSERT_TRUE(info.ok()) << info.status();
    EXPECT_EQ(info->default_budget_seconds(), 12);
    EXPECT_EQ(info->limits().max_queued_jobs(), 3u);
    EXPECT_EQ(info->default_stage_budget_seconds().at("outliers"), 0.5);
    EXPECT_EQ(info->default_stage_budget_seconds().at("smoothing"), 2);
  }
  const auto samples = Scrape(server.metrics_port());
  EXPECT_EQ(samples.at("scanprep_budget_seconds"), 12);
  EXPECT_EQ(samples.at("scanprep_queue_capacity"), 3);
  EXPECT_EQ(samples.at(GrpcHandled("GetInfo", "OK")), 1);
  EXPECT_EQ(server.Terminate(), 0);
}

TEST(ServerBinary, BadBudgetFlagsExitOneWithTheReason) {
  const CommandResult r =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --stage_budgets=sharpen=1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("--stage_budgets entry 'sharpen=1': unknown stage 'sharpen'"));
  const CommandResult proxies = RunCommand(std::string(SCANPREP_SERVER_BINARY) +
                                           " --plaintext --trusted_proxies=10.0.0.0/8,10.0.0.1/8");
  EXPECT_EQ(proxies.exit_code, 1);
  EXPECT_THAT(proxies.output, HasSubstr("--trusted_proxies: '10.0.0.1/8' has address bits set "
                                        "beyond its /8 prefix"));
  const CommandResult listen =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --plaintext --metrics_listen=nowhere");
  EXPECT_EQ(listen.exit_code, 1);
  EXPECT_THAT(listen.output, HasSubstr("metrics_listen: 'nowhere' is not HOST:PORT"));
}

TEST(ServerBinary, BadConnectionFlagsExitOneWithTheReason) {
  const CommandResult r =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --plaintext --max_connection_age=0s");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("--max_connection_age must be at least 1ms (got 0)"));
}

// The client ports of the Process calls in a server's call log ("process peer=ipv4:IP:PORT").
std::set<std::string> CallerPorts(const std::string& log) {
  std::set<std::string> ports;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) {
    const size_t at = line.find("process peer=");
    if (at == std::string::npos) continue;
    const std::string peer = line.substr(at, line.find(' ', at + 8) - at);
    ports.insert(peer.substr(peer.rfind(':') + 1));
  }
  return ports;
}

// With --max_connection_age the server sends GOAWAY to older connections, so a client's channel
// reconnects (re-resolving its target, which is how it reaches replicas added since) and no call
// fails on the way; without it, one connection serves every call (the control).
TEST(ServerBinary, MaxConnectionAgeMakesClientsReconnectWithoutFailingCalls) {
  const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("outliers");
  for (const bool limited : {false, true}) {
    ServerProcess server(limited ? std::vector<std::string>{"--max_connection_age=300ms",
                                                            "--max_connection_age_grace=30s"}
                                 : std::vector<std::string>{});
    ASSERT_GT(server.port(), 0);
    {
      auto client = client::ScanPrepClient::Connect(server.target());
      for (int i = 0; i < 6; ++i) {
        auto result = client.Process(header, scan.cloud);
        ASSERT_TRUE(result.ok()) << "call " << i << ": " << result.status();
        absl::SleepFor(absl::Milliseconds(250));
      }
    }
    const std::set<std::string> ports = CallerPorts(server.Log());
    if (limited) {
      EXPECT_GE(ports.size(), 2u) << server.Log();
    } else {
      EXPECT_EQ(ports.size(), 1u) << server.Log();
    }
    EXPECT_EQ(server.Terminate(), 0);
  }
}

// --help lists the server's own flags (absl shows the flags of the file named like the program
// unless told where they live); absl's usage flags exit 1.
TEST(ServerBinary, HelpListsTheServersFlags) {
  const CommandResult r = RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --help");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("Flags from server/main.cc"));
  for (const char* flag : {"--listen", "--plaintext", "--max_points_per_job", "--threads"}) {
    EXPECT_THAT(r.output, HasSubstr(flag));
  }
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("No flags matched")));
}

TEST(ServerBinary, RefusesToStartWithoutTransportSecurityOrPlaintext) {
  const CommandResult r =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --listen=127.0.0.1:0 --metrics_listen=");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output,
              HasSubstr("no transport security configured: give --tls_cert and "
                        "--tls_key (and --tls_client_ca for mutual TLS), or --plaintext"));
  const CommandResult missing =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) +
                 " --tls_cert=/nonexistent.pem --tls_key=/nonexistent.key");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.output, HasSubstr("--tls_cert: file not found: /nonexistent.pem"));
}

TEST(ServerBinary, LimitFlagsReachGetInfo) {
  ServerProcess server({"--max_chunk_points=1000", "--max_bytes_per_call=123456",
                        "--max_scans_per_job=7", "--max_calls_per_peer=3"});
  ASSERT_GT(server.port(), 0);
  {
    auto info = client::ScanPrepClient::Connect(server.target()).GetInfo(absl::Seconds(10));
    ASSERT_TRUE(info.ok()) << info.status();
    EXPECT_EQ(info->limits().max_chunk_points(), 1000u);
    EXPECT_EQ(info->limits().max_bytes_per_call(), 123456u);
    EXPECT_EQ(info->limits().max_scans_per_job(), 7u);
    EXPECT_EQ(info->limits().max_calls_per_peer(), 3u);
    EXPECT_EQ(info->limits().max_message_bytes(), 64u << 20);
  }
  EXPECT_EQ(server.Terminate(), 0);
}

TEST(ServerBinary, SigtermLetsTheInFlightCallFinishThenExitsZero) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  auto stub = v1::ScanPrep::NewStub(
      grpc::CreateChannel(server.target(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  auto stream = stub->Process(&context);
  ASSERT_TRUE(stream->Write(HeaderRequest(SimpleHeader(), 500)));
  ASSERT_TRUE(stream->Write(ChunkRequest(LineChunk(500))));
  v1::ProcessResponse response;
  ASSERT_TRUE(stream->Read(&response));  // the upload is acknowledged: the call is in flight

  std::thread terminate([&] { EXPECT_EQ(server.Terminate(), 0); });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ASSERT_TRUE(stream->Write(EndRequest({ChunkRequest(LineChunk(500))})));
  stream->WritesDone();
  bool report = false;
  while (stream->Read(&response)) report |= response.has_report();
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_TRUE(report);
  terminate.join();
}

TEST(ServerBinary, SigtermDuringALongStageExitsWithinTheGracePeriodPlusOneSecond) {
  // No plan-cost limit: the job is meant to be long.
  ServerProcess server({"--grace_period=1s", "--max_plan_cost=0"});
  ASSERT_GT(server.port(), 0);
  auto stub = v1::ScanPrep::NewStub(
      grpc::CreateChannel(server.target(), grpc::InsecureChannelCredentials()));
  // Smoothing 7 times (the most allowed) over 64 neighbours of 300,000 points: far longer than
  // the grace period.
  const GeneratedScan scan = NoisyPlaneWithSpikes(545, 0.5f);
  v1::JobHeader header = SimpleHeader(0.5);
  header.set_total_points(scan.cloud.size());
  auto& params = *header.mutable_options()->mutable_params();
  params["neighbourhoods.k"] = "64";
  params["smoothing.iterations"] = "7";
  grpc::ClientContext context;
  auto stream = stub->Process(&context);
  ASSERT_TRUE(stream->Write(HeaderRequest(header)));
  StreamChecksum sent;
  for (size_t begin = 0; begin < scan.cloud.size(); begin += client::kDefaultChunkPoints) {
    v1::ProcessRequest request;
    client::RequestChunk(scan.cloud, begin,
                         std::min(scan.cloud.size(), begin + client::kDefaultChunkPoints), false,
                         request.mutable_points());
    sent.Add(request.points());
    ASSERT_TRUE(stream->Write(request));
  }
  v1::ProcessRequest end;
  *end.mutable_end() = sent.End();
  ASSERT_TRUE(stream->Write(end));
  stream->WritesDone();
  v1::ProcessResponse response;
  while (stream->Read(&response) && response.progress().stage() != "smoothing") {
  }
  ASSERT_EQ(response.progress().stage(), "smoothing");

  const auto signalled = std::chrono::steady_clock::now();
  std::thread terminate([&] { EXPECT_EQ(server.Terminate(), 0); });
  while (stream->Read(&response)) {
  }
  const grpc::Status status = stream->Finish();
  terminate.join();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  EXPECT_LE(seconds, 2.0) << "exit took " << seconds << " s";  // grace 1 s + 1 s
  // Cut short, not finished: the server was shutting down.
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
}

TEST(Cli, ProcessesTwoRegisteredBunnyScans) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  const fs::path dir = data / "stanford_bunny_range_scans";
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const fs::path out = fs::path(::testing::TempDir()) / "cli_bunny.ply";
  fs::remove(out);
  const CommandResult r =
      RunCli((dir / "bun000.ply").string() + " " + (dir / "bun045.ply").string() + " --conf " +
             (dir / "bun.conf").string() + " --unit m --stages outliers -o " + out.string() +
             " --server " + server.target() + " --include_removed=false");
  // The subcommand comes first.
  ASSERT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("unknown command"));

  const CommandResult ok =
      RunCli("process " + (dir / "bun000.ply").string() + " " + (dir / "bun045.ply").string() +
             " --conf " + (dir / "bun.conf").string() + " --unit m --stages outliers -o " +
             out.string() + " --server " + server.target());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("points: 80353 received, 0 invalid"));
  std::vector<std::string> ply_warnings;
  auto cloud = io::ReadPly(out, ply_warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_THAT(ok.output, HasSubstr("wrote " + std::to_string(cloud->size()) + " points"));
  EXPECT_GT(cloud->size(), 0.9 * 80'353);
  EXPECT_LT(cloud->size(), 80'353u);
  // Registered by the server, in metres: both scans overlap in one bunny-sized box.
  const auto [min_x, max_x] = std::minmax_element(cloud->x.begin(), cloud->x.end());
  EXPECT_LT(*max_x - *min_x, 0.25);
  EXPECT_GT(*max_x - *min_x, 0.1);
  // Counts in the summary are plain integers (outliers.removed=1234, not 1.234e+03).
  EXPECT_THAT(ok.output, ::testing::ContainsRegex("outliers.removed=[0-9]+ "));
  EXPECT_THAT(ok.output, ::testing::Not(::testing::ContainsRegex("removed=[0-9.]+e\\+")));

  // `info --json`: GetInfo's answer as JSON with the proto's field names.
  const CommandResult json = RunCli("info --json --server " + server.target());
  ASSERT_EQ(json.exit_code, 0) << json.output;
  google::protobuf::Struct parsed;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json.output, &parsed).ok())
      << json.output;
  // 64-bit integers are JSON strings in protobuf's JSON mapping.
  EXPECT_EQ(
      parsed.fields().at("limits").struct_value().fields().at("max_chunk_points").string_value(),
      "65536");
  EXPECT_EQ(server.Terminate(), 0);
}

// The sanitizer builds run a job some ten times slower; they check this path with 1 M points and
// leave the 4 M job's timing to the Release build.
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SCANPREP_SANITIZED_BUILD
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SCANPREP_SANITIZED_BUILD
#endif
#ifdef SCANPREP_SANITIZED_BUILD
constexpr char kProgressJobPoints[] = "1000000";
#else
constexpr char kProgressJobPoints[] = "2000000";
#endif

// A long job (the issue's case was 4 M points: stages in a jumbled order, 0 % through 25 s stages,
// nothing when not on a terminal; 2 M points here, 30 s on two cores, where 4 M took 130-175 s of
// the suite's six minutes and the shortest stages still showed one line inside them at 1 M): with
// stderr a pipe the CLI prints plain lines, and they reach every stage of the plan in execution
// order, each with progress strictly inside it, while the job's percentage never goes back and an
// ETA appears. The summary lists the stages in the same order.
TEST(Cli, ProgressOfAMultiMillionPointJobReachesEveryStageInOrder) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("progress_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const CommandResult sim = RunCli(absl::StrCat("simulate --points ", kProgressJobPoints,
                                                " --scans 2 -o ", (dir / "big.ply").string()));
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const CommandResult r =
      RunCli("process " + (dir / "big_frontal.ply").string() + " " +
             (dir / "big_oblique.ply").string() + " --job " + (dir / "big.job.json").string() +
             " -o " + (dir / "out.ply").string() + " --timeout 240s --server " + server.target());
  fs::remove_all(dir);
  // Some 45 s here; should it hang, where the server's threads were says which side did.
  ASSERT_EQ(r.exit_code, 0) << r.output
                            << (r.timed_out ? ThreadStates(server.pid()) + server.Log() : "");

  // "[  12.3 s] processing  41%  ETA 9.8 s  [3/7] normals 62%"
  const std::regex line(
      R"(\[ *[0-9.]+ s\] processing +([0-9]+)%  ETA ([0-9.]+ s|\.\.\.)  \[([0-9]+)/([0-9]+)\] ([a-z]+) ([0-9]+)%)");
  std::vector<std::string> order;     // stages as their lines first appear
  std::map<std::string, int> inside;  // lines strictly inside each stage (0 < % < 100)
  int last_job = 0, last_index = 0, count = 0;
  bool eta = false;
  std::istringstream in(r.output);
  for (std::string text; std::getline(in, text);) {
    std::smatch m;
    if (!std::regex_search(text, m, line)) continue;
    const int job = std::stoi(m[1]), index = std::stoi(m[3]), stage_pct = std::stoi(m[6]);
    count = std::stoi(m[4]);
    EXPECT_GE(job, last_job) << text;
    EXPECT_GE(index, last_index) << text;
    last_job = job, last_index = index;
    eta = eta || m[2] != "...";
    if (order.empty() || order.back() != m[5]) order.push_back(m[5]);
    if (stage_pct > 0 && stage_pct < 100) ++inside[m[5]];
  }
  const std::vector<std::string> plan = {"neighbourhoods", "normals",      "outliers",
                                         "measures",       "registration", "correction",
                                         "health",         "smoothing",    "simplification"};
  EXPECT_EQ(order, plan) << r.output;
  EXPECT_EQ(count, static_cast<int>(plan.size()));
  for (const std::string& stage : plan) EXPECT_GT(inside[stage], 0) << stage << "\n" << r.output;
  EXPECT_TRUE(eta) << r.output;
  EXPECT_THAT(r.output, HasSubstr("] upload "));
  EXPECT_THAT(r.output, HasSubstr("] download "));
  // The summary table: the same stages, in the same order.
  size_t at = r.output.find("stage ");
  for (const std::string& stage : plan) {
    at = r.output.find("\n" + stage + " ", at);
    EXPECT_NE(at, std::string::npos) << stage << " not in order in the summary";
  }
  // After a job this size gRPC's library teardown waited 10 s; the server now ends without it.
  const absl::Time stop = absl::Now();
  EXPECT_EQ(server.Terminate(), 0);
  EXPECT_LT(absl::Now() - stop, absl::Seconds(3));
}

// Every kind of scan file in ../shared/data through the CLI and the default pipeline: each comes
// back with all its valid points (removed ones included, flagged) and its scan structure, the
// counts and structure being the data README's.
TEST(Cli, ProcessesEveryScanFileInTheSharedData) {
  SCANPREP_REQUIRE_SHARED_DATA(data);
  const fs::path dir = fs::path(::testing::TempDir()) / ("shared_" + std::to_string(getpid()));
  fs::create_directories(dir);
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  struct Case {
    std::string file, flags;
    size_t points;
    size_t grid_rows;  // the file's grid rows (range_grid, organised HEIGHT); 0 = no grid
    size_t scanlines;  // without a grid: distinct scanlines in the result (0 = none)
  };
  const Case cases[] = {
      {"stanford_bunny_range_scans/bun000.ply", "--unit m", 40'256, 400, 0},
      {"stanford_happy_stand_range_scans/happyStandRight_24.ply", "--unit m", 75'582, 660, 0},
      {"pcl_rs1_laser_scene/rs1.pcd", "--unit m", 289'541, 0, 0},
      // Organised 640 x 480 with NaN holes: the valid points.
      {"pcl_table_scene_mug_stereo/table_scene_mug_stereo_textured.pcd", "--unit m", 209'280, 480,
       0},
      {"cognex_laser_line_scan/triangulated.xyz", "--unit mm --profile_gap 50", 2'628, 0, 6},
      {"e57_bunny_sample/bunnyDouble.e57", "", 30'571, 0, 0},  // metres without --unit
  };
  for (const Case& c : cases) {
    const fs::path out = dir / (fs::path(c.file).stem().string() + ".ply");
    const CommandResult r =
        RunCli("process " + (data / c.file).string() + " " + c.flags + " --include_removed -o " +
               out.string() + " --progress off --server " + server.target());
    ASSERT_EQ(r.exit_code, 0) << c.file << "\n" << r.output;
    std::vector<std::string> warnings;
    auto cloud = io::ReadScanFile(out, warnings);
    ASSERT_TRUE(cloud.ok()) << c.file << ": " << cloud.status();
    EXPECT_EQ(cloud->size(), c.points) << c.file;
    EXPECT_TRUE(cloud->has_normals()) << c.file;
    const size_t outliers = std::count_if(cloud->flags.begin(), cloud->flags.end(),
                                          [](uint8_t f) { return (f & kRemovedOutlier) != 0; });
    const std::set<uint32_t> lines(cloud->scanline.begin(), cloud->scanline.end());
    // Outliers are few in these scans (the unit is right, so the radii fit the data).
    EXPECT_LT(outliers, c.points / 100) << c.file;
    // Range grids and organised clouds: a scanline per grid row holding points, at most the
    // file's rows and more than a third of them; a laser-line file: one per profile.
    if (c.grid_rows > 0) {
      EXPECT_LE(lines.size(), c.grid_rows) << c.file;
      EXPECT_GT(lines.size(), c.grid_rows / 3) << c.file;
    } else {
      EXPECT_EQ(lines.size(), c.scanlines) << c.file;
    }
  }
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// A LAS file from a line scanner (20 sweeps of 400 points over a gently curved strip, the scan
// direction flipping each sweep): every point comes back, in one scanline per sweep.
TEST(Cli, ProcessesALasLineScan) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("las_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::vector<LasPoint> points;
  for (int sweep = 0; sweep < 20; ++sweep) {
    for (int k = 0; k < 400; ++k) {
      const int x = 100 * k;  // 0.1 mm apart (scale 0.001 mm)
      points.push_back({.x = x,
                        .y = 200 * sweep,
                        .z = static_cast<int32_t>(x * static_cast<double>(x) * 1e-5),
                        .intensity = 1000,
                        .direction = sweep % 2 == 1});
    }
  }
  const std::string las = LasFile(2, 1, points);
  std::ofstream(dir / "strip.las", std::ios::binary).write(las.data(), las.size());
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const CommandResult r =
      RunCli("process " + (dir / "strip.las").string() + " --unit mm --include_removed -o " +
             (dir / "out.ply").string() + " --progress off --server " + server.target());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("20 scanlines by scan direction"));
  std::vector<std::string> warnings;
  auto cloud = io::ReadScanFile(dir / "out.ply", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(cloud->size(), 8'000u);
  EXPECT_EQ(std::set<uint32_t>(cloud->scanline.begin(), cloud->scanline.end()).size(), 20u);
  EXPECT_TRUE(cloud->has_normals());
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// A pipe: the scan on standard input, the result on standard output, in formats named by flags;
// the same points, normals and flags as the job sent from and written to files, and nothing but
// the result on standard output (the summary goes to standard error).
TEST(Cli, ReadsStandardInputAndWritesStandardOutput) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("pipe_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const CommandResult sim = RunCli("simulate --points 20000 -o " + (dir / "sim.ply").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string flags =
      " --unit mm --include_removed --progress off --server " + server.target();
  const CommandResult file = RunCli("process " + (dir / "sim.ply").string() + flags + " -o " +
                                    (dir / "file.pcd").string());
  ASSERT_EQ(file.exit_code, 0) << file.output;
  const CommandResult pipe =
      RunCli("process - --input_format ply -o - --output_format pcd" + flags + " < " +
             (dir / "sim.ply").string() + " > " + (dir / "pipe.pcd").string());
  ASSERT_EQ(pipe.exit_code, 0) << pipe.output;
  EXPECT_THAT(pipe.output, HasSubstr("points to standard output"));  // on standard error
  std::vector<std::string> warnings;
  auto from_file = io::ReadScanFile(dir / "file.pcd", warnings);
  auto from_pipe = io::ReadScanFile(dir / "pipe.pcd", warnings);
  ASSERT_TRUE(from_file.ok()) << from_file.status();
  ASSERT_TRUE(from_pipe.ok()) << from_pipe.status();
  ASSERT_GT(from_file->size(), 19'000u);
  EXPECT_EQ(from_pipe->x, from_file->x);
  EXPECT_EQ(from_pipe->z, from_file->z);
  EXPECT_EQ(from_pipe->nx, from_file->nx);
  EXPECT_EQ(from_pipe->flags, from_file->flags);
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// The PNG's width and height from its header (the pixels are preview_test's business).
std::pair<uint32_t, uint32_t> PngSize(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(24, '\0');
  in.read(head.data(), 24);
  if (head.compare(1, 3, "PNG") != 0) return {0, 0};
  auto be32 = [&](int at) {
    return (uint32_t{static_cast<uint8_t>(head[at])} << 24) |
           (uint32_t{static_cast<uint8_t>(head[at + 1])} << 16) |
           (uint32_t{static_cast<uint8_t>(head[at + 2])} << 8) | static_cast<uint8_t>(head[at + 3]);
  };
  return {be32(16), be32(20)};
}

// `process --preview` draws the job's input and result side by side and still writes only the
// kept points unless asked; `preview` draws any written cloud in one panel.
TEST(Cli, PreviewsOfAJobAndOfAFile) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("preview_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const CommandResult sim = RunCli("simulate --points 20000 -o " + (dir / "sim.ply").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string job = "process " + (dir / "sim.ply").string() + " --job " +
                          (dir / "sim.job.json").string() + " -o " + (dir / "out.ply").string() +
                          " --server " + server.target();
  // A preview is PNG: any other extension is refused before the job is read or sent.
  CommandResult jpg = RunCli(job + " --preview " + (dir / "job.jpg").string());
  EXPECT_EQ(jpg.exit_code, 2) << jpg.output;
  EXPECT_THAT(jpg.output, HasSubstr("job.jpg: cannot write a preview as '.jpg' (previews are "
                                    "written as PNG: give a .png file)"));
  EXPECT_FALSE(fs::exists(dir / "job.jpg"));
  EXPECT_FALSE(fs::exists(dir / "out.ply"));
  const CommandResult r = RunCli(job + " --preview " + (dir / "job.png").string() +
                                 " --report_json " + (dir / "report.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(PngSize(dir / "job.png"), (std::pair<uint32_t, uint32_t>(1280, 576)));
  // Every JSON the CLI writes has the proto's snake_case field names: the report (with the
  // client's phases) as `info --json` and `load --json` do, and the job file of `simulate`.
  for (const char* file : {"report.json", "sim.job.json"}) {
    std::ifstream in(dir / file);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_THAT(text, ::testing::Not(::testing::ContainsRegex("\"[a-z]+[A-Z][A-Za-z]*\":")))
        << file << ": " << text;
  }
  std::ifstream report_in(dir / "report.json");
  google::protobuf::Struct report;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(
                  std::string((std::istreambuf_iterator<char>(report_in)),
                              std::istreambuf_iterator<char>()),
                  &report)
                  .ok());
  EXPECT_TRUE(report.fields().contains("points_received"));
  EXPECT_TRUE(report.fields().contains("processing_seconds"));
  EXPECT_TRUE(report.fields().at("phases").struct_value().fields().contains("total_seconds"));
  std::vector<std::string> warnings;
  auto out = io::ReadScanFile(dir / "out.ply", warnings);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->CountKept(), out->size());  // the removed points came back for the picture only
  EXPECT_THAT(r.output, HasSubstr(absl::StrCat("wrote ", out->size(), " points to ")));
  const CommandResult one =
      RunCli("preview " + (dir / "out.ply").string() + " -o " + (dir / "file.png").string());
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_EQ(PngSize(dir / "file.png"), (std::pair<uint32_t, uint32_t>(640, 576)));
  EXPECT_EQ(RunCli("preview " + (dir / "out.ply").string()).exit_code, 2);  // no -o
  jpg = RunCli("preview " + (dir / "out.ply").string() + " -o " + (dir / "file.JPG").string());
  EXPECT_EQ(jpg.exit_code, 2) << jpg.output;
  EXPECT_THAT(jpg.output, HasSubstr("cannot write a preview as '.JPG'"));
  EXPECT_FALSE(fs::exists(dir / "file.JPG"));
  EXPECT_EQ(RunCli("preview " + (dir / "out.ply").string() + " -o " + (dir / "upper.PNG").string())
                .exit_code,
            0);
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// PLY, PCD and XYZ in, PLY, PCD and XYZ out: the same job sent from each input format, and its
// result written in each output format (removed points included, flagged), reads back with the
// same points, normals and flags as the PLY round trip.
TEST(Cli, EveryFormatThroughTheServiceAndBack) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("formats_" + std::to_string(getpid()));
  fs::create_directories(dir / "pcd");
  fs::create_directories(dir / "xyz");
  const CommandResult sim = RunCli("simulate --points 20000 -o " + (dir / "sim.ply").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  std::vector<std::string> ply_warnings;
  auto input = io::ReadPly(dir / "sim.ply", ply_warnings);
  ASSERT_TRUE(input.ok()) << input.status();
  ASSERT_TRUE(io::WritePcd(dir / "pcd" / "sim.pcd", *input).ok());
  ASSERT_TRUE(io::WriteXyz(dir / "xyz" / "sim.xyz", *input).ok());
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  auto process = [&](const fs::path& in, const fs::path& out) {
    const CommandResult r =
        RunCli("process " + in.string() + " --job " + (dir / "sim.job.json").string() +
               " --include_removed -o " + out.string() + " --server " + server.target());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<std::string> warnings;
    auto cloud = io::ReadScanFile(out, warnings);
    EXPECT_TRUE(cloud.ok()) << out << ": " << cloud.status();
    return cloud.ok() ? *cloud : PointCloud{};
  };
  const PointCloud reference = process(dir / "sim.ply", dir / "out.ply");
  ASSERT_GT(reference.size(), 19'000u);
  ASSERT_TRUE(reference.has_normals());
  ASSERT_GT(reference.size(), reference.CountKept());  // removed points are in it, flagged
  const std::pair<fs::path, fs::path> runs[] = {
      {dir / "sim.ply", dir / "out.pcd"},
      {dir / "sim.ply", dir / "out.xyz"},
      {dir / "pcd" / "sim.pcd", dir / "from_pcd.ply"},
      {dir / "xyz" / "sim.xyz", dir / "from_xyz.ply"},
  };
  for (const auto& [in, out] : runs) {
    const PointCloud cloud = process(in, out);
    ASSERT_EQ(cloud.size(), reference.size()) << in << " -> " << out;
    EXPECT_EQ(cloud.x, reference.x) << in << " -> " << out;
    EXPECT_EQ(cloud.y, reference.y) << in << " -> " << out;
    EXPECT_EQ(cloud.z, reference.z) << in << " -> " << out;
    EXPECT_EQ(cloud.nx, reference.nx) << in << " -> " << out;
    EXPECT_EQ(cloud.nz, reference.nz) << in << " -> " << out;
    EXPECT_EQ(cloud.flags, reference.flags) << in << " -> " << out;
  }
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// A laser-line profile file in text form: --profile_gap splits it into scanlines at the jumps
// between profiles, and the result carries them; without the flag (the control) it has none.
TEST(Cli, ProfileGapSplitsATextScanIntoScanlines) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("gap_" + std::to_string(getpid()));
  fs::create_directories(dir);
  {
    std::ofstream xyz(dir / "profiles.xyz");
    for (int line = 0; line < 3; ++line) {
      for (int i = 0; i < 60; ++i) xyz << 0.5 * i << " " << 5.0 * line << " 0\n";
    }
  }
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  auto scanlines = [&](const std::string& flag) -> std::set<uint32_t> {
    const fs::path out = dir / "out.ply";
    const CommandResult r =
        RunCli("process " + (dir / "profiles.xyz").string() + " --stages normals" + flag +
               " --include_removed -o " + out.string() + " --server " + server.target());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<std::string> ply_warnings;
    auto cloud = io::ReadPly(out, ply_warnings);
    EXPECT_TRUE(cloud.ok()) << cloud.status();
    if (!cloud.ok() || !cloud->has_scanlines()) return {};
    return std::set<uint32_t>(cloud->scanline.begin(), cloud->scanline.end());
  };
  EXPECT_EQ(scanlines(" --profile_gap 2"), (std::set<uint32_t>{0, 1, 2}));
  EXPECT_EQ(scanlines(""), std::set<uint32_t>{});
  const CommandResult bad = RunCli("process " + (dir / "profiles.xyz").string() +
                                   " --profile_gap -1 -o " + (dir / "x.ply").string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("--profile_gap: '-1' is not a length >= 0"));
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// Issue 40, item 2, as a plant met it: one stray return at 1e8 mm in a text scan (floats are
// 8 mm apart there) is left out and named, the scan processed; --strict fails on it (exit 4).
TEST(Cli, OneStrayPointFarOutIsLeftOutNotTheScan) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("stray_" + std::to_string(getpid()));
  fs::create_directories(dir);
  {
    std::ofstream xyz(dir / "plane.xyz");
    for (int line = 0; line < 30; ++line) {
      for (int i = 0; i < 30; ++i) xyz << 0.5 * i << " " << 0.5 * line << " 0\n";
      if (line == 12) xyz << "1e8 6 0\n";
    }
  }
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string job = "process " + (dir / "plane.xyz").string() + " --unit mm -o " +
                          (dir / "out.ply").string() + " --progress off --server " +
                          server.target();
  const CommandResult r = RunCli(job);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("1 of 901 points were excluded"));
  std::vector<std::string> warnings;
  auto cloud = io::ReadScanFile(dir / "out.ply", warnings);
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_GT(cloud->size(), 0u);
  for (size_t i = 0; i < cloud->size(); ++i) EXPECT_LT(cloud->x[i], 20.f) << i;
  const CommandResult strict = RunCli(job + " --strict");
  EXPECT_EQ(strict.exit_code, 4) << strict.output;
  EXPECT_THAT(strict.output, HasSubstr("POINTS_INVALID"));
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// Issue 40, item 1, as a plant met it: a file in metres sent as millimetres with no spacing or u
// stated passed --strict. Now its unit is UNCHECKED, which --strict fails on (exit 4); the
// control states the spacing (in the file's real unit, so the slip is visible) and is SUSPECT.
TEST(Cli, StrictFailsAScanWhoseUnitNothingConfirms) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("unchecked_" + std::to_string(getpid()));
  fs::create_directories(dir);
  {
    std::ofstream xyz(dir / "metres.xyz");
    for (int line = 0; line < 30; ++line) {
      for (int i = 0; i < 30; ++i) xyz << 0.0005 * i << " " << 0.0005 * line << " 0\n";
    }
  }
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string job = "process " + (dir / "metres.xyz").string() + " --unit mm -o " +
                          (dir / "out.ply").string() + " --progress off --server " +
                          server.target();
  const CommandResult lax = RunCli(job);
  ASSERT_EQ(lax.exit_code, 0) << lax.output;
  EXPECT_THAT(lax.output, HasSubstr("warning UNIT_UNCHECKED"));
  const CommandResult strict = RunCli(job + " --strict");
  EXPECT_EQ(strict.exit_code, 4) << strict.output;
  EXPECT_THAT(strict.output, HasSubstr("(reason UNIT_UNCHECKED)"));
  const CommandResult stated = RunCli(job + " --strict --scanline_spacing 0.5");
  EXPECT_EQ(stated.exit_code, 4) << stated.output;
  EXPECT_THAT(stated.output, HasSubstr("(reason UNIT_SUSPECT)"));
  fs::remove_all(dir);
  EXPECT_EQ(server.Terminate(), 0);
}

// Every command answers --help (and -h) with its usage and flags, exit 0.
TEST(Cli, EveryCommandHasHelp) {
  for (const char* command : {"process", "info", "load", "simulate"}) {
    for (const char* help : {"--help", "-h"}) {
      const CommandResult r = RunCli(std::string(command) + " " + help);
      EXPECT_EQ(r.exit_code, 0) << command << " " << help << ": " << r.output;
      EXPECT_THAT(r.output, HasSubstr(absl::StrCat("usage: scanprep ", command)));
      EXPECT_THAT(r.output, HasSubstr("--"));
    }
  }
}

// A PLY whose points carry a scan column (as scanprep's own output does) holds several scans:
// each value becomes its own scan, named STEM#VALUE, instead of the column being dropped.
TEST(Cli, APerPointScanColumnSplitsTheFileIntoScans) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const fs::path tmp = ::testing::TempDir();
  PointCloud two;
  for (int i = 0; i < 400; ++i) {
    two.x.push_back(static_cast<float>(i % 20));
    two.y.push_back(static_cast<float>(i / 20));
    two.z.push_back(i < 200 ? 0.f : 0.05f);
    two.scan.push_back(i < 200 ? 3 : 7);
  }
  two.flags.assign(two.size(), 0);
  const fs::path in = tmp / "two_scans.ply", out = tmp / "two_scans_out.ply";
  ASSERT_TRUE(io::WritePly(in, two).ok());
  const CommandResult r = RunCli("process " + in.string() + " --stages outliers -o " +
                                 out.string() + " --server " + server.target());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("its scan column holds 2 scans, sent as two_scans#3 … "
                                  "two_scans#7"));
  std::vector<std::string> ply_warnings;
  auto result = io::ReadPly(out, ply_warnings);
  ASSERT_TRUE(result.ok()) << result.status();
  std::set<uint32_t> scans(result->scan.begin(), result->scan.end());
  EXPECT_EQ(scans, (std::set<uint32_t>{0, 1}));
}

// A PCD file's VIEWPOINT reaches the server as the scan's camera_position, so the viewing quality
// has a sensor; PCL's default VIEWPOINT means "unknown" and both the client and the stage say so.
TEST(Cli, APcdViewpointIsTheScansSensorOrigin) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const fs::path tmp = ::testing::TempDir();
  for (const std::string viewpoint : {"5 5 100 1 0 0 0", "0 0 0 1 0 0 0"}) {
    std::string pcd =
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 20\n"
        "HEIGHT 20\nVIEWPOINT " +
        viewpoint + "\nPOINTS 400\nDATA ascii\n";
    for (int i = 0; i < 400; ++i) absl::StrAppend(&pcd, i % 20 * 0.5, " ", i / 20 * 0.5, " 0\n");
    const fs::path in = tmp / "grid.pcd", out = tmp / "grid_out.ply";
    std::ofstream(in) << pcd;
    const CommandResult r = RunCli("process " + in.string() + " --stages measures -o " +
                                   out.string() + " --server " + server.target());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const bool known = viewpoint != "0 0 0 1 0 0 0";
    EXPECT_EQ(r.output.find("VIEWPOINT is PCL's default") == std::string::npos, known) << r.output;
    EXPECT_EQ(r.output.find("has neither sensor poses") == std::string::npos, known) << r.output;
    EXPECT_THAT(r.output, HasSubstr("coordinates are taken as millimetres (PCL writes PCD files "
                                    "in metres: pass --unit m if so)"));
  }
}

TEST(Cli, BadInvocationsExitNonZeroWithAClearMessage) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const fs::path tmp = ::testing::TempDir();
  const fs::path scan = tmp / "cli_line.xyz";
  {
    std::ofstream f(scan);
    for (int i = 0; i < 50; ++i) f << i * 0.5 << " 0 0\n";
  }
  const std::string base = "process " + scan.string() + " -o " + (tmp / "x.ply").string() +
                           " --server " + server.target();

  // Refused by the server as invalid: 4, "fix the input".
  CommandResult r = RunCli(base + " --stages sharpen");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_THAT(r.output, HasSubstr("INVALID_ARGUMENT: options.stages: unknown stage 'sharpen'"));

  r = RunCli(base + " --param outliers.multiplier=two");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_THAT(r.output, HasSubstr("'two' is not a finite number"));

  r = RunCli("process " + (tmp / "missing.ply").string() + " -o x.ply");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("missing.ply"));

  // A misspelt parameter: the server names the one meant.
  r = RunCli(base + " --param smoothing.iteratons=3");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_THAT(r.output, HasSubstr("options.params['smoothing.iteratons']: unknown parameter (did "
                                  "you mean 'smoothing.iterations'?)"));

  // A flag value that does not parse is a usage error (2), found before anything is read: the
  // scan file does not exist, and no server is asked.
  const std::string local = "process " + (tmp / "missing.xyz").string() + " -o " +
                            (tmp / "x.ply").string() + " --server 127.0.0.1:1";
  for (const auto& [flags, message] : std::vector<std::pair<std::string, std::string>>{
           {" --unit furlong", "unknown unit 'furlong'"},
           {" --param smoothing.lambda", "--param 'smoothing.lambda': expected name=value"},
           {" --uncertainty -1", "--uncertainty: '-1' is not a length >= 0"},
           {" --profile_gap wide", "--profile_gap: 'wide' is not a length >= 0"},
           {" --timeout soon", "--timeout"},
           {" --budget -3", "--budget"}}) {
    r = RunCli(local + flags);
    EXPECT_EQ(r.exit_code, 2) << flags << ": " << r.output;
    EXPECT_THAT(r.output, HasSubstr(message)) << flags;
    EXPECT_THAT(r.output, ::testing::Not(HasSubstr("missing.xyz"))) << flags;
  }
  r = RunCli("simulate --points 1000");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("-o OUT.ply is required"));
  r = RunCli("simulate --points many -o " + (tmp / "s.ply").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunCli("load --concurrency 4 --simulate 1000");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--server HOST:PORT is required"));
  r = RunCli("load --server 127.0.0.1:1 --concurrency 0 --simulate 1000");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Control: a file that cannot be read is not a usage error.
  r = RunCli(local);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("missing.xyz"));
  // An empty scan file is refused by its reader, naming it, before anything is sent.
  std::ofstream(tmp / "empty.xyz") << "# no points\n";
  r = RunCli("process " + (tmp / "empty.xyz").string() + " -o " + (tmp / "x.ply").string() +
             " --server " + server.target());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr((tmp / "empty.xyz").string() + ": no points in the file"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("total_points")));

  r = RunCli(base + " --frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("unknown flag '--frobnicate'"));

  r = RunCli(base + " --progress loud");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("--progress loud: expected auto, live, plain or off"));

  // The output: required, a format it can write (a usage error, 2, before anything is sent), and
  // a report that cannot be written fails the command.
  r = RunCli("process " + scan.string() + " --server " + server.target());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("-o OUT.ply is required"));
  r = RunCli("process " + scan.string() + " -o " + (tmp / "x.obj").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("the result is written as PLY, PCD, LAS or XYZ"));
  r = RunCli("process " + scan.string() + " -o -");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("say its format with --output_format"));
  r = RunCli("process - -o " + (tmp / "x.ply").string() + " < " + scan.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("say its format with --input_format"));
  r = RunCli("process " + scan.string() + " - - --input_format ply -o x.ply");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("can be given once"));
  r = RunCli("process " + (tmp / "x.obj").string() + " -o x.ply");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("unsupported file extension '.obj'"));
  r = RunCli(base + " --report_json " + (tmp / "no_such_dir" / "r.json").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("no_such_dir does not exist"));

  // Over its budget: the output is written and the exit code is 0, or 5 when asked to fail.
  r = RunCli(base + " --stages outliers --budget 0.000000001");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("MISSED"));
  fs::remove(tmp / "x.ply");
  r = RunCli(base + " --stages outliers --budget 0.000000001 --fail_on_budget_miss");
  EXPECT_EQ(r.exit_code, 5) << r.output;
  EXPECT_THAT(r.output, HasSubstr("missed its budget"));
  EXPECT_TRUE(fs::exists(tmp / "x.ply"));
  r = RunCli(base + " --stages outliers --budget 600 --fail_on_budget_miss");
  EXPECT_EQ(r.exit_code, 0) << r.output;

  // No server: 3, "retry later".
  r = RunCli("process " + scan.string() + " -o x.ply --server 127.0.0.1:1 --timeout 5s");
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_THAT(r.output, HasSubstr("UNAVAILABLE"));

  // The job file is JobHeader's JSON form; the flags override it. The enum value names from
  // before they took their enum's prefix ("MILLIMETRE", "LINE") are still read.
  const fs::path job = tmp / "job.json";
  std::ofstream(job) << R"({"unit": "LENGTH_UNIT_MILLIMETRE", "scannerKind": "SCANNER_KIND_LINE"})";
  r = RunCli(base + " --job " + job.string() + " --stages outliers");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ofstream(job)
      << R"({"jobId": "j1", "unit": "MILLIMETRE", "scanner_kind": "LINE", "options": {"stages": ["nope"]}})";
  r = RunCli(base + " --job " + job.string());
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_THAT(r.output, HasSubstr("unknown stage 'nope'"));
  r = RunCli(base + " --job " + job.string() + " --stages outliers");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("points: 50 received"));
  std::ofstream(job) << R"({"unit": "MILLIMETRE", "colour": "red"})";
  r = RunCli(base + " --job " + job.string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.output, HasSubstr("not a JobHeader in JSON"));
}

// A job over the server's size limit: the reason is printed, there is no retry delay, and the
// exit code is 4 ("fix the input"), not 3 ("retry later").
TEST(Cli, JobTooLargePrintsTheReasonAndExitsFour) {
  ServerProcess server({"--max_points_per_job=20"});
  ASSERT_GT(server.port(), 0);
  const fs::path scan = fs::path(::testing::TempDir()) / "cli_too_large.xyz";
  {
    std::ofstream f(scan);
    for (int i = 0; i < 50; ++i) f << i * 0.5 << " 0 0\n";
  }
  const CommandResult r =
      RunCli("process " + scan.string() + " -o " +
             (fs::path(::testing::TempDir()) / "x.ply").string() + " --server " + server.target());
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_THAT(r.output, HasSubstr("RESOURCE_EXHAUSTED"));
  EXPECT_THAT(r.output, HasSubstr("(reason JOB_TOO_LARGE)"));
}

TEST(Cli, InfoPrintsStagesAndLimits) {
  ServerProcess server({"--max_points_per_job=1000000"});
  ASSERT_GT(server.port(), 0);
  const CommandResult r = RunCli("info --server " + server.target());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("1000000 points per job"));
  EXPECT_THAT(r.output, HasSubstr("a job estimated at 416 B/point"));
  EXPECT_THAT(r.output, HasSubstr("a plan's work at most 3× the default's"));
  EXPECT_THAT(r.output, HasSubstr("outliers"));
  EXPECT_THAT(r.output, HasSubstr("outliers.multiplier"));
}

// A live process's memory line `key` ("VmHWM:" the peak resident memory, "VmRSS:" the current)
// from /proc/PID/status, in bytes; 0 when unreadable.
uint64_t StatusBytes(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key, 0) == 0) return std::stoull(line.substr(key.size())) * 1024;
  }
  return 0;
}

uint64_t PeakRss(pid_t pid) { return StatusBytes(pid, "VmHWM:"); }

// The server's peak RSS over twelve 250,000-point jobs sent at once (`scanprep load`, twelve
// workers) to a server with `memory_capacity` and room for all twelve to run together: twelve
// slots and twelve arena threads (with fewer threads the jobs would take turns in the arena and
// their peaks would not add up).
uint64_t PeakRssOfTwelveConcurrentJobs(uint64_t memory_capacity) {
  ServerProcess server({"--memory_capacity=" + std::to_string(memory_capacity),
                        "--max_points_per_job=300000", "--max_concurrent_jobs=12",
                        "--max_queued_jobs=12", "--max_calls_per_peer=12", "--threads=12"});
  EXPECT_GT(server.port(), 0);
  const CommandResult r =
      RunCli("load --server " + server.target() +
             " --simulate 250000 --scans 2 --concurrency 12 --max_jobs 12 --timeout 300s");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("errors: 0"));
  return PeakRss(server.pid());
}

// Each job is estimated at 16 MiB + 250,051 x 416 B = 120.8 MB, so a 300 MB capacity runs two at a
// time and a 4 GB one all twelve (434 MB measured, 2026-11-25).
TEST(ServerBinary, ConcurrentJobsStayWithinTheMemoryCapacity) {
#ifdef SCANPREP_SANITIZED
  // ASan's shadow memory and its quarantine of freed blocks (up to 256 MB) are part of the RSS
  // and not of the estimate; the measured bytes per point hold for the Release build only.
  GTEST_SKIP() << "measures the Release server's memory; sanitizers add their own";
#endif
  constexpr uint64_t kCapacity = 300'000'000;
  // The control: with room for all twelve the same jobs overlap and take more than the capacity,
  // so the bounded run cannot pass by accident.
  const uint64_t unbounded = PeakRssOfTwelveConcurrentJobs(4'000'000'000);
  EXPECT_GT(unbounded, kCapacity);
  const uint64_t bounded = PeakRssOfTwelveConcurrentJobs(kCapacity);
  EXPECT_GT(bounded, 0u);
  EXPECT_LT(bounded, kCapacity);
  std::cout << "peak RSS of 12 x 250,000-point jobs: " << unbounded / 1e6
            << " MB with a 4 GB capacity, " << bounded / 1e6 << " MB with a " << kCapacity / 1e6
            << " MB capacity\n";
}

// One simulated 1 M-point job (two scans) processed by a server whose estimate is 1 B/point
// (the test hook --test_bytes_per_point), so the job reserves 17 MiB and genuinely needs about
// ten times that, whatever inputs the real estimate covers; `guard_flag` turns the memory guard
// on or off. Returns the server's peak resident memory above its idle resident memory, the CLI's
// result and the guard's trip counter.
struct UnderEstimatedJob {
  uint64_t peak_above_idle = 0;
  CommandResult cli;
  double trips = -1;
};
UnderEstimatedJob ProcessUnderEstimatedJob(const fs::path& dir, const std::string& guard_flag) {
  ServerProcess server({"--memory_capacity=300000000", "--test_bytes_per_point=1", guard_flag});
  EXPECT_GT(server.port(), 0);
  const uint64_t idle = StatusBytes(server.pid(), "VmRSS:");
  UnderEstimatedJob run;
  run.cli =
      RunCli("process " + (dir / "guard_frontal.ply").string() + " " +
             (dir / "guard_oblique.ply").string() + " --job " + (dir / "guard.job.json").string() +
             " -o " + (dir / "guard_out.ply").string() + " --server " + server.target());
  run.peak_above_idle = PeakRss(server.pid()) - idle;
  run.trips = Sample(server.metrics_port(), "scanprep_memory_guard_trips_total");
  return run;
}

// The memory guard holds a job that needs more than its reservation to the reservation plus the
// stated margin and ends it with the reason; without the guard the same job goes past that bound,
// so the guarded run cannot pass by accident.
TEST(ServerBinary, MemoryGuardHoldsAJobToItsReservation) {
#ifdef SCANPREP_SANITIZED
  GTEST_SKIP() << "the guard is off in sanitizer builds, whose own memory is resident";
#endif
  const fs::path dir = ::testing::TempDir();
  const CommandResult simulated =
      RunCli("simulate --points 1000000 --scans 2 -o " + (dir / "guard.ply").string());
  ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
  // At most 1,000,000 points at 1 B each on top of the fixed per-job 16 MiB.
  const uint64_t bound = server::kJobOverheadBytes + 1'000'000 + server::kMemoryGuardMarginBytes;

  const UnderEstimatedJob guarded = ProcessUnderEstimatedJob(dir, "--memory_guard=true");
  EXPECT_EQ(guarded.cli.exit_code, 4) << guarded.cli.output;
  EXPECT_THAT(guarded.cli.output, HasSubstr("RESOURCE_EXHAUSTED"));
  EXPECT_THAT(guarded.cli.output, HasSubstr("(reason MEMORY_RESERVATION_EXCEEDED)"));
  EXPECT_THAT(guarded.cli.output, HasSubstr("this job reserved 17 MiB"));
  EXPECT_EQ(guarded.trips, 1);
  EXPECT_GT(guarded.peak_above_idle, 0u);
  EXPECT_LE(guarded.peak_above_idle, bound);

  const UnderEstimatedJob control = ProcessUnderEstimatedJob(dir, "--memory_guard=false");
  EXPECT_EQ(control.cli.exit_code, 0) << control.cli.output;
  EXPECT_EQ(control.trips, 0);
  EXPECT_GT(control.peak_above_idle, bound);
  std::cout << "a 1 M-point job reserving " << (bound - server::kMemoryGuardMarginBytes) / 1e6
            << " MB peaked " << guarded.peak_above_idle / 1e6 << " MB above the idle server with "
            << "the memory guard, " << control.peak_above_idle / 1e6 << " MB without; bound "
            << bound / 1e6 << " MB\n";
}

}  // namespace
}  // namespace scanprep::testing
