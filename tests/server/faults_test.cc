// SPDX-License-Identifier: Apache-2.0
// Faults from the client's side against the real service in-process: clients that vanish mid-
// upload and mid-download, deadlines that expire inside every stage and in upload and download,
// and a long run of malformed calls. The server must answer each with the right status, give its
// memory back, log the refusals, and keep serving.
#include <malloc.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/server/metrics_scrape.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

// Under ASan, TSan or UBSan builds (tools/run-sanitizers.sh) the sanitizer's allocator replaces
// glibc's, so glibc's heap statistics say nothing about what is live: the memory checks are skipped
// there and LeakSanitizer checks for leaks instead. Everything else still runs.
#ifdef SCANPREP_SANITIZED
constexpr bool kHeapStatsTrackLiveMemory = false;
#else
constexpr bool kHeapStatsTrackLiveMemory = true;
#endif

// Bytes allocated and not yet freed, over all of glibc's heaps and its mmapped blocks, in MiB.
// Resident memory would also count freed pages the allocator keeps and one heap per thread that
// ever allocated, which varies with scheduling and made the check flaky on a loaded machine.
double LiveHeapMib() {
  const struct mallinfo2 info = mallinfo2();
  return static_cast<double>(info.uordblks + info.hblkhd) / (1 << 20);
}

// gRPC frees a finished call's buffers on its own threads, after the client saw the status:
// waits up to 10 s for live memory to come within `limit_mib` of `baseline_mib`, and returns the
// last reading. A leak stays above the limit and fails the caller's check.
double SettledLiveHeapMib(double baseline_mib, double limit_mib) {
  double live = LiveHeapMib();
  for (int i = 0; i < 100 && live - baseline_mib >= limit_mib; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    live = LiveHeapMib();
  }
  return live;
}

server::ServerOptions WithMetrics(server::ServerOptions options = {}) {
  options.metrics_listen = "127.0.0.1:0";
  return options;
}

std::string Handled(const std::string& code) { return GrpcHandled("Process", code); }

v1::JobHeader OutliersHeader() {
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("outliers");
  return header;
}

// A scan big enough that holding it shows in resident memory: about 300,000 points.
const GeneratedScan& LargeScan() {
  static const GeneratedScan* scan = new GeneratedScan(NoisyPlaneWithSpikes(545, 0.5f));
  return *scan;
}

// Uploads the header and about half of `scan`, waits for the server to acknowledge a chunk, then
// cancels the call.
grpc::Status DisconnectMidUpload(v1::ScanPrep::Stub& stub, const PointCloud& cloud) {
  grpc::ClientContext context;
  auto stream = stub.Process(&context);
  v1::JobHeader header = OutliersHeader();
  header.set_total_points(cloud.size());
  bool open = stream->Write(HeaderRequest(header));
  for (size_t begin = 0; open && begin < cloud.size() / 2; begin += client::kDefaultChunkPoints) {
    v1::ProcessRequest request;
    client::RequestChunk(cloud, begin, std::min(cloud.size(), begin + client::kDefaultChunkPoints),
                         false, request.mutable_points());
    open = stream->Write(request);
  }
  v1::ProcessResponse response;
  EXPECT_TRUE(stream->Read(&response));
  context.TryCancel();
  return stream->Finish();
}

// A client whose receive window stays at HTTP/2's initial 64 KiB: without window growth (BDP
// probing) a server writing a result of megabytes blocks until the client reads, so a client that
// stops reading at the first result chunk really leaves the server mid-download. With probing the
// window can grow past the whole result on a loaded machine and the server finishes first.
client::ScanPrepClient FixedWindowClient(const InProcessServer& server) {
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  return client::ScanPrepClient(
      grpc::CreateCustomChannel(server.target(), grpc::InsecureChannelCredentials(), arguments));
}

TEST(Faults, ClientsThatVanishMidUploadOrMidDownloadLeaveNoMemoryBehind) {
  InProcessServer server(WithMetrics());
  const int metrics = server.server().metrics_port();
  auto stub = server.Stub();
  client::ScanPrepClient client = FixedWindowClient(server);
  const GeneratedScan& scan = LargeScan();
  // A round first, so thread stacks, pools and heaps exist before the baseline.
  constexpr int kRounds = 6, kWarmUp = 1;
  double baseline = 0;
  for (int round = 1; round <= kRounds; ++round) {
    if (round == kWarmUp + 1) baseline = LiveHeapMib();
    EXPECT_EQ(DisconnectMidUpload(*stub, scan.cloud).error_code(), grpc::StatusCode::CANCELLED);

    client::CallCanceller canceller;
    auto result = client.Process(OutliersHeader(), scan.cloud,
                                 {.progress =
                                      [&](const v1::Progress& p) {
                                        if (p.phase() == v1::Progress::PHASE_DOWNLOAD)
                                          canceller.Cancel();
                                      },
                                  .canceller = &canceller});
    EXPECT_EQ(result.status().code(), absl::StatusCode::kCancelled);
    // The server saw both calls end as cancelled and released them.
    ASSERT_TRUE(WaitForSample(metrics, Handled("Canceled"), 2 * round)) << ScrapeText(metrics);
  }
  // One job of this size holds well over 30 MiB (cloud, neighbour graph, messages), its upload
  // messages alone 4 MiB: a leak of either in each of the 10 calls ends far above the limit. Live
  // memory without a leak wanders by up to 6 MiB from round to round on a loaded machine (gRPC's
  // and TBB's caches), without a trend.
  constexpr double kLimitMib = 15;
  const double after = SettledLiveHeapMib(baseline, kLimitMib);
  if (kHeapStatsTrackLiveMemory) {
    EXPECT_LT(after - baseline, kLimitMib)
        << "live heap: baseline " << baseline << " MiB, after " << after << " MiB";
  }
  RecordProperty("live_heap_baseline_mib", std::to_string(baseline));
  RecordProperty("live_heap_after_mib", std::to_string(after));
  EXPECT_TRUE(client.Process(OutliersHeader(), scan.cloud).ok());
}

// Holds the job at the start of `stage` until `until`: a deadline set before `until` then
// expires while that stage runs.
struct StageHold {
  std::mutex mu;
  std::string stage;
  absl::Time until;
  std::atomic<bool> held{false};

  void OnProgress(std::string_view s, double fraction) {
    absl::Time release;
    {
      std::lock_guard lock(mu);
      if (s != stage || fraction != 0) return;
      release = until;
    }
    held = true;
    absl::SleepFor(release - absl::Now());
  }
};

TEST(Faults, ADeadlineExpiringInsideEveryStageEndsWithDeadlineExceeded) {
  StageHold hold;
  server::ServerOptions options = WithMetrics();
  options.on_progress = [&hold](std::string_view s, double f) { hold.OnProgress(s, f); };
  InProcessServer server(options);
  const int metrics = server.server().metrics_port();
  client::ScanPrepClient client = server.Client();
  const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);

  // The default pipeline's stages as they run, nested ones included.
  auto full = client.Process(SimpleHeader(0.5), scan.cloud);
  ASSERT_TRUE(full.ok()) << full.status();
  std::vector<std::string> stages;
  for (const v1::StageReport& s : full->report.stages()) stages.push_back(s.name());
  ASSERT_GE(stages.size(), 5u);

  // Upload, every stage and processing before it take milliseconds on this scan (tens of them
  // under ThreadSanitizer on a loaded machine, where 400 ms once ran out before the last stage);
  // the deadline then passes while the held stage is still running.
#ifdef SCANPREP_SANITIZED
  constexpr absl::Duration kDeadline = absl::Seconds(2);
#else
  constexpr absl::Duration kDeadline = absl::Milliseconds(400);
#endif
  int expired = 0;
  for (const std::string& stage : stages) {
    SCOPED_TRACE(stage);
    {
      std::lock_guard lock(hold.mu);
      hold.stage = stage;
      hold.until = absl::Now() + kDeadline + absl::Milliseconds(150);
    }
    hold.held = false;
    auto result = client.Process(SimpleHeader(0.5), scan.cloud, {.timeout = kDeadline});
    EXPECT_EQ(result.status().code(), absl::StatusCode::kDeadlineExceeded);
    EXPECT_TRUE(hold.held) << "the job never reached the stage";
    // The server's own answer, not only the client's timer.
    EXPECT_TRUE(WaitForSample(metrics, Handled("DeadlineExceeded"), ++expired));
  }
  {
    std::lock_guard lock(hold.mu);
    hold.stage.clear();
  }
  auto again = client.Process(SimpleHeader(0.5), scan.cloud, {.timeout = absl::Seconds(30)});
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->report.stages_size(), full->report.stages_size());
}

TEST(Faults, ADeadlineExpiringDuringUploadOrDownloadEndsWithDeadlineExceeded) {
  InProcessServer server(WithMetrics());
  const int metrics = server.server().metrics_port();
  auto stub = server.Stub();
  {  // Upload: the client sends a chunk, then nothing until the deadline has passed.
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(300));
    auto stream = stub->Process(&context);
    ASSERT_TRUE(stream->Write(HeaderRequest(SimpleHeader(), 100)));
    ASSERT_TRUE(stream->Write(ChunkRequest(LineChunk(100))));
    v1::ProcessResponse response;
    while (stream->Read(&response)) {
    }
    EXPECT_EQ(stream->Finish().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
    EXPECT_TRUE(WaitForSample(metrics, Handled("DeadlineExceeded"), 1));
  }
  {  // Download: the client stops reading at the first result chunk until its deadline passed.
     // gRPC completes the server's writes into the transport's buffers, so the server may well
     // have sent the whole result (and count the call OK) before the deadline: the client must
     // still see DEADLINE_EXCEEDED and the server must end the call and go on serving.
    const GeneratedScan scan = NoisyPlaneWithSpikes(150, 0.5f);
    client::ScanPrepClient client = server.Client();
    // The deadline must pass during the download: twice the job's time on this build (a
    // sanitizer's is many times Release's; a fixed 2 s expired inside the stages under TSan),
    // plus a second.
    const absl::Time start = absl::Now();
    ASSERT_TRUE(client.Process(OutliersHeader(), scan.cloud, {.timeout = absl::Seconds(120)}).ok());
    const absl::Time deadline = absl::Now() + 2 * (absl::Now() - start) + absl::Seconds(1);
    bool stalled = false;
    auto result =
        client.Process(OutliersHeader(), scan.cloud,
                       {.timeout = deadline - absl::Now(), .progress = [&](const v1::Progress& p) {
                          if (p.phase() != v1::Progress::PHASE_DOWNLOAD || stalled) return;
                          stalled = true;
                          absl::SleepFor(deadline - absl::Now() + absl::Milliseconds(200));
                        }});
    EXPECT_TRUE(stalled);
    EXPECT_EQ(result.status().code(), absl::StatusCode::kDeadlineExceeded);
    const auto samples = Scrape(metrics);
    auto count = [&](const std::string& code) {
      const auto it = samples.find(Handled(code));
      return it == samples.end() ? 0.0 : it->second;
    };
    // The upload's call, the timing run and this one.
    EXPECT_EQ(count("OK") + count("DeadlineExceeded"), 3) << ScrapeText(metrics);
  }
  EXPECT_TRUE(RawCall(*stub, {HeaderRequest(OutliersHeader()), ChunkRequest(LineChunk(100))}).ok());
}

// Malformed calls of every kind the assembler refuses, in turn. Coordinates are 4242.5, so the
// log can be checked for point data.
std::vector<std::vector<v1::ProcessRequest>> MalformedCalls() {
  v1::PointChunk marked = LineChunk(50);
  for (int i = 0; i < marked.xyz_size(); ++i) marked.set_xyz(i, 4242.5f);
  v1::JobHeader no_unit = SimpleHeader();
  no_unit.clear_unit();
  v1::JobHeader unknown_stage = SimpleHeader();
  unknown_stage.mutable_options()->add_stages("sharpen");
  v1::JobHeader two_scans = SimpleHeader();
  *two_scans.add_scans() = two_scans.scans(0);
  v1::PointChunk ragged = marked;
  ragged.add_xyz(1.f);
  v1::PointChunk bad_quality = marked;
  for (int i = 0; i < 50; ++i) bad_quality.add_quality(i == 7 ? 3.f : 0.5f);
  v1::PointChunk too_big = LineChunk(65'537);
  return {
      {ChunkRequest(marked)},                                          // points before the header
      {HeaderRequest(no_unit), ChunkRequest(marked)},                  // unit unspecified
      {HeaderRequest(unknown_stage)},                                  // unknown stage
      {HeaderRequest(SimpleHeader()), ChunkRequest(ragged)},           // xyz not in threes
      {HeaderRequest(SimpleHeader()), ChunkRequest(bad_quality)},      // quality out of range
      {HeaderRequest(two_scans), ChunkRequest(marked)},                // scan_index missing
      {HeaderRequest(SimpleHeader()), ChunkRequest(too_big)},          // chunk over the limit
      {HeaderRequest(SimpleHeader()), HeaderRequest(SimpleHeader())},  // second header
      {HeaderRequest(SimpleHeader())},                                 // no points
  };
}

TEST(Faults, AThousandMalformedCallsKeepMemoryFlatAndAreLogged) {
  std::ostringstream log;
  std::string log_text;
  {
    server::ServerOptions options;
    options.log = &log;
    options.max_log_lines_per_second = 1'000'000;  // this test counts every call's line
    InProcessServer server(options);
    auto stub = server.Stub();
    const auto calls = MalformedCalls();
    auto run = [&](int n) {
      int refused = 0;
      for (int i = 0; i < n; ++i) {
        const grpc::Status s = RawCall(*stub, calls[i % calls.size()]);
        refused += s.error_code() == grpc::StatusCode::INVALID_ARGUMENT ||
                   s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
      }
      return refused;
    };
    EXPECT_EQ(run(100), 100);  // warm-up: connections, thread pools, the log's buffer
    const double baseline = LiveHeapMib();
    EXPECT_EQ(run(1000), 1000);
    constexpr double kLimitMib = 4;
    const double after = SettledLiveHeapMib(baseline, kLimitMib);
    if (kHeapStatsTrackLiveMemory) {
      EXPECT_LT(after - baseline, kLimitMib)
          << "live heap: baseline " << baseline << " MiB, after " << after << " MiB";
    }
    RecordProperty("live_heap_growth_mib", std::to_string(after - baseline));

    const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);
    auto good = server.Client().Process(OutliersHeader(), scan.cloud);
    ASSERT_TRUE(good.ok()) << good.status();
    EXPECT_EQ(good->report.points_received(), scan.cloud.size());
  }
  log_text = log.str();  // the server is gone: nothing writes to the log any more

  // One warning line per refused call, with the peer and the reason, never the points.
  int warnings = 0;
  std::istringstream lines(log_text);
  for (std::string line; std::getline(lines, line);) {
    if (line.find(" W process peer=ipv4:127.0.0.1:") != std::string::npos) ++warnings;
  }
  EXPECT_EQ(warnings, 1100);
  EXPECT_THAT(
      log_text,
      HasSubstr("status=INVALID_ARGUMENT message=\"chunk 0: quality[7] = 3 is outside [0, 1]\""));
  EXPECT_THAT(
      log_text,
      HasSubstr("status=RESOURCE_EXHAUSTED message=\"chunk 0: 65537 points exceed the limit"));
  EXPECT_THAT(log_text, HasSubstr(" I process peer=ipv4:127.0.0.1:"));  // the good call
  EXPECT_THAT(log_text, ::testing::Not(HasSubstr("4242")));
}

}  // namespace
}  // namespace scanprep::testing
