// SPDX-License-Identifier: Apache-2.0
// Several jobs at once through one server: concurrent jobs on the shared worker arena,
// cancellations among them, and a shutdown while jobs run. CI also runs these under
// ThreadSanitizer (tools/run-sanitizers.sh tsan).
#include <atomic>
#include <condition_variable>
#include <future>
#include <mutex>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

constexpr int kJobs = 4;  // the server's default max_concurrent_jobs: all of them run at once
constexpr int kServerThreads = 2;

const GeneratedScan& Scan() {
  static const GeneratedScan* scan = new GeneratedScan(NoisyPlaneWithSpikes(80, 0.5f));
  return *scan;
}

// x, y, z of every returned point, for bit-for-bit comparison of two runs.
std::vector<float> Coordinates(const PointCloud& c) {
  std::vector<float> xyz;
  xyz.reserve(3 * c.size());
  for (size_t i = 0; i < c.size(); ++i) xyz.insert(xyz.end(), {c.x[i], c.y[i], c.z[i]});
  return xyz;
}

// The default pipeline on the scan with the server to itself: what every concurrent run must
// reproduce exactly (each stage is deterministic for a given cloud, whatever runs beside it).
std::vector<float> ResultAlone(InProcessServer& server) {
  auto alone = server.Client().Process(SimpleHeader(), Scan().cloud);
  EXPECT_TRUE(alone.ok()) << alone.status();
  if (!alone.ok()) return {};
  // Spikes removed and flat parts thinned: the pipeline did work, so equality means something.
  EXPECT_LT(alone->cloud.size(), Scan().cloud.size() * 9 / 10);
  EXPECT_GT(alone->cloud.size(), 0u);
  return Coordinates(alone->cloud);
}

TEST(Concurrency, JobsRunningTogetherEachGiveTheResultOfAJobAlone) {
  InProcessServer server;
  const std::vector<float> expected = ResultAlone(server);
  std::vector<std::future<absl::StatusOr<client::ProcessResult>>> jobs;
  for (int j = 0; j < kJobs; ++j) {
    jobs.push_back(std::async(
        std::launch::async, [&] { return server.Client().Process(SimpleHeader(), Scan().cloud); }));
  }
  for (auto& job : jobs) {
    auto result = job.get();
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(Coordinates(result->cloud), expected);
  }
}

TEST(Concurrency, CancellingHalfTheJobsLeavesTheOtherHalfIntact) {
  InProcessServer server;
  const std::vector<float> expected = ResultAlone(server);
  std::vector<client::CallCanceller> cancellers(kJobs);
  std::vector<std::future<absl::StatusOr<client::ProcessResult>>> jobs;
  for (int j = 0; j < kJobs; ++j) {
    client::CallOptions options{.canceller = &cancellers[j]};
    if (j % 2 == 0) {
      options.progress = [&cancellers, j](const v1::Progress& p) {
        if (p.phase() == v1::Progress::PHASE_PROCESSING) cancellers[j].Cancel();
      };
    }
    jobs.push_back(std::async(std::launch::async, [&server, options] {
      return server.Client().Process(SimpleHeader(), Scan().cloud, options);
    }));
  }
  for (int j = 0; j < kJobs; ++j) {
    auto result = jobs[j].get();
    if (j % 2 == 0) {
      EXPECT_EQ(result.status().code(), absl::StatusCode::kCancelled) << result.status();
    } else {
      ASSERT_TRUE(result.ok()) << result.status();
      EXPECT_EQ(Coordinates(result->cloud), expected);
    }
  }
  // The cancelled jobs gave back their slots.
  EXPECT_EQ(ResultAlone(server), expected);
}

// Holds jobs at the start of smoothing until released, so a shutdown meets running jobs. A held
// job blocks its worker thread, so at most the arena's thread count are held at once; the other
// jobs wait for a thread, also in flight.
class SmoothingGate {
 public:
  void OnProgress(std::string_view stage, double fraction) {
    if (stage != "smoothing" || fraction != 0) return;
    std::unique_lock lock(mu_);
    ++held_;
    changed_.notify_all();
    changed_.wait_for(lock, std::chrono::seconds(60), [&] { return open_; });
  }
  bool WaitUntilHolding(int jobs) {
    std::unique_lock lock(mu_);
    return changed_.wait_for(lock, std::chrono::seconds(60), [&] { return held_ == jobs; });
  }
  void Open() {
    std::lock_guard lock(mu_);
    open_ = true;
    changed_.notify_all();
  }

 private:
  std::mutex mu_;
  std::condition_variable changed_;
  int held_ = 0;
  bool open_ = false;
};

TEST(Concurrency, ShutdownLetsRunningJobsFinishAndRefusesNewOnes) {
  std::vector<float> expected;
  {
    InProcessServer reference;
    expected = ResultAlone(reference);
  }
  SmoothingGate gate;
  server::ServerOptions options;
  options.on_progress = [&gate](std::string_view s, double f) { gate.OnProgress(s, f); };
  options.threads = kServerThreads;
  InProcessServer server(options);
  std::vector<std::future<absl::StatusOr<client::ProcessResult>>> jobs;
  for (int j = 0; j < kJobs; ++j) {
    jobs.push_back(std::async(
        std::launch::async, [&] { return server.Client().Process(SimpleHeader(), Scan().cloud); }));
  }
  ASSERT_TRUE(gate.WaitUntilHolding(kServerThreads));

  server.server().Drain();
  const auto refused = server.Client().Process(SimpleHeader(), Scan().cloud);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kUnavailable) << refused.status();
  auto shutdown =
      std::async(std::launch::async, [&] { server.server().Shutdown(absl::Seconds(60)); });
  gate.Open();
  for (auto& job : jobs) {
    auto result = job.get();
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(Coordinates(result->cloud), expected);
  }
  EXPECT_EQ(shutdown.wait_for(std::chrono::seconds(60)), std::future_status::ready);
}

}  // namespace
}  // namespace scanprep::testing
