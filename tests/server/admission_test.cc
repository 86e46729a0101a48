// SPDX-License-Identifier: Apache-2.0
// Admission control: the AdmissionQueue on its own (fake clock, so the expected-wait arithmetic
// is exact), then through the real service with jobs held open by clients that sent a header and
// a chunk and wait. Every wait is bounded; no sleep decides an outcome.
#include <future>
#include <set>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include "absl/cleanup/cleanup.h"
#include "core/base/status_macros.h"
#include "server/admission/admission.h"
#include "server/transport/cidr.h"
#include "tests/server/metrics_scrape.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using server::AdmissionQueue;
using ::testing::HasSubstr;
using ::testing::Not;

// Polls `condition` every millisecond for at most 10 s.
template <typename Fn>
bool Eventually(Fn condition) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

// An AdmissionQueue with its own metrics and a clock the test moves by hand.
class QueueUnderTest {
 public:
  QueueUnderTest(int max_concurrent, int max_queued,
                 uint64_t memory_capacity = std::numeric_limits<uint64_t>::max())
      : queue_({.max_concurrent_jobs = max_concurrent,
                .max_queued_jobs = max_queued,
                .memory_capacity_bytes = memory_capacity,
                .now = [this] { return now(); }},
               metrics_) {}

  AdmissionQueue& queue() { return queue_; }
  absl::Time now() {
    std::lock_guard lock(mu_);
    return now_;
  }
  void Advance(absl::Duration d) {
    std::lock_guard lock(mu_);
    now_ += d;
  }
  // A call that claims `bytes`, uploads at once and takes a slot with all of them reserved;
  // every call comes from one client host unless a test names another.
  absl::StatusOr<AdmissionQueue::Ticket> AdmitNow(uint64_t bytes = 0,
                                                  const std::string& host = "host") {
    return AdmitAndTakeSlot(host, bytes, absl::InfiniteFuture(), [] { return false; });
  }
  // AdmitNow on another thread; the future resolves when the call got a slot or failed.
  std::future<absl::StatusOr<AdmissionQueue::Ticket>> AdmitAsync(
      absl::Time deadline = absl::InfiniteFuture(), std::atomic<bool>* cancelled = nullptr,
      uint64_t bytes = 0, std::string host = "host") {
    return std::async(std::launch::async, [this, deadline, cancelled, bytes, host] {
      return AdmitAndTakeSlot(host, bytes, deadline,
                              [cancelled] { return cancelled != nullptr && cancelled->load(); });
    });
  }
  // Admit `bytes` on another thread and wait until the call is queued (or already decided).
  std::future<absl::StatusOr<AdmissionQueue::Ticket>> AdmitQueued(
      uint64_t bytes, std::atomic<bool>* cancelled = nullptr, const std::string& host = "host") {
    const int before = queue_.queued();
    auto f = AdmitAsync(absl::InfiniteFuture(), cancelled, bytes, host);
    EXPECT_TRUE(Eventually([&] {
      return queue_.queued() > before ||
             f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
    }));
    return f;
  }
  absl::StatusOr<AdmissionQueue::Ticket> AdmitAndTakeSlot(const std::string& host, uint64_t bytes,
                                                          absl::Time deadline,
                                                          const std::function<bool()>& cancelled) {
    auto ticket = queue_.Admit(host, bytes, 0, deadline, cancelled);
    if (!ticket.ok()) return ticket;
    SCANPREP_RETURN_IF_ERROR(ticket->TakeSlot(cancelled));
    return ticket;
  }
  double Metric(const std::string& key) {
    const auto samples = ParseSamples(registry_.Serialize());
    const auto it = samples.find(key);
    return it == samples.end() ? -1 : it->second;
  }

 private:
  std::mutex mu_;
  absl::Time now_ = absl::UnixEpoch();
  metrics::Registry registry_;
  server::ServiceMetrics metrics_{registry_};
  AdmissionQueue queue_;
};

template <typename T>
bool Ready(const std::future<T>& f) {
  return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

TEST(AdmissionQueue, RunsUpToTheLimitQueuesUpToTheCapacityRefusesTheRest) {
  QueueUnderTest q(/*max_concurrent=*/2, /*max_queued=*/1);
  EXPECT_EQ(q.Metric("scanprep_queue_capacity"), 1);
  auto a = q.AdmitNow();
  auto b = q.AdmitNow();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(q.queue().in_flight(), 2);

  auto waiting = q.AdmitAsync();
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  EXPECT_EQ(q.Metric("scanprep_jobs_queued"), 1);
  EXPECT_EQ(q.Metric("scanprep_jobs_in_flight"), 2);

  auto refused = q.AdmitNow();
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(),
              HasSubstr("its limit of 3 jobs (max_concurrent_jobs 2 + max_queued_jobs 1): 2 "
                        "running, 1 waiting for a slot, 0 uploading; the queue is full"));
  EXPECT_EQ(q.Metric("scanprep_jobs_rejected_total{reason=\"queue_full\"}"), 1);
  EXPECT_FALSE(Ready(waiting));

  // A freed slot passes to the waiting call; the count of slots held stays at the limit.
  q.Advance(absl::Seconds(3));
  { auto release = std::move(*a); }
  auto granted = waiting.get();
  ASSERT_TRUE(granted.ok()) << granted.status();
  EXPECT_EQ(q.queue().in_flight(), 2);
  EXPECT_EQ(q.queue().queued(), 0);
  // Two immediate admissions waited 0 s, the queued one 3 s on the fake clock.
  EXPECT_EQ(q.Metric("scanprep_phase_seconds_count{phase=\"queue\"}"), 3);
  EXPECT_EQ(q.Metric("scanprep_phase_seconds_sum{phase=\"queue\"}"), 3);
}

TEST(AdmissionQueue, WaitingCallsAreServedInArrivalOrder) {
  QueueUnderTest q(1, 2);
  auto running = q.AdmitNow();
  ASSERT_TRUE(running.ok());
  auto first = q.AdmitAsync();
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  auto second = q.AdmitAsync();
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 2; }));

  { auto release = std::move(*running); }
  auto first_slot = first.get();
  ASSERT_TRUE(first_slot.ok());
  EXPECT_EQ(q.queue().queued(), 1);
  EXPECT_FALSE(Ready(second));
  { auto release = std::move(*first_slot); }
  EXPECT_TRUE(second.get().ok());
}

// Host A queues three calls behind its running one, then host B one: B has not been served, A
// has, so B's call takes the next slot (second, not fourth as in arrival order), and then A's in
// their order.
TEST(AdmissionQueue, HostsThatContendTakeTurnsLeastRecentlyServedFirst) {
  QueueUnderTest q(/*max_concurrent=*/1, /*max_queued=*/8);
  auto running = q.AdmitNow(0, "A");
  ASSERT_TRUE(running.ok());
  std::atomic<bool> give_up{false};  // so that a failed test ends instead of waiting forever
  std::vector<std::future<absl::StatusOr<AdmissionQueue::Ticket>>> a;
  for (int i = 0; i < 3; ++i) a.push_back(q.AdmitQueued(0, &give_up, "A"));
  auto b = q.AdmitQueued(0, &give_up, "B");
  absl::Cleanup end_waits = [&] { give_up = true; };  // before the futures wait for their calls
  ASSERT_EQ(q.queue().queued(), 4);

  { auto release = std::move(*running); }
  ASSERT_EQ(b.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  auto b_slot = b.get();
  ASSERT_TRUE(b_slot.ok()) << b_slot.status();
  EXPECT_EQ(q.queue().queued(), 3);
  for (auto& f : a) EXPECT_FALSE(Ready(f));
  { auto release = std::move(*b_slot); }
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].wait_for(std::chrono::seconds(10)), std::future_status::ready);
    auto slot = a[i].get();
    ASSERT_TRUE(slot.ok()) << slot.status();
    for (size_t j = i + 1; j < a.size(); ++j) EXPECT_FALSE(Ready(a[j]));
  }
}

// Alone, a host may fill every slot and every queue place; its next call is refused only because
// the queue is full.
TEST(AdmissionQueue, OneHostAloneMayTakeEverySlotAndQueuePlace) {
  QueueUnderTest q(/*max_concurrent=*/2, /*max_queued=*/2);
  auto first = q.AdmitNow(0, "A");
  auto second = q.AdmitNow(0, "A");
  ASSERT_TRUE(first.ok() && second.ok());
  auto third = q.AdmitQueued(0, nullptr, "A");
  auto fourth = q.AdmitQueued(0, nullptr, "A");
  EXPECT_EQ(q.queue().queued(), 2);
  const auto refused = q.AdmitNow(0, "A");
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(), HasSubstr("the queue is full"));
  { auto release = std::move(*first); }
  EXPECT_TRUE(third.get().ok());
  { auto release = std::move(*second); }
  EXPECT_TRUE(fourth.get().ok());
}

// Issue 39 finding 1: host A holds every slot and queue place and resubmits at once; each call
// of host B takes the place of A's newest waiting call (refused QUEUE_FULL, saying why, with a
// RetryInfo) until both hold or await as many calls (3 of the 6 places); then B's next call is
// refused like anyone's at a full queue. B runs at the next free slot, A at the one after.
TEST(AdmissionQueue, AHostThatFloodsTheQueueGivesPlacesToAnotherUntilTheyAreEven) {
  QueueUnderTest q(/*max_concurrent=*/2, /*max_queued=*/4);
  std::atomic<bool> give_up{false};
  std::vector<std::future<absl::StatusOr<AdmissionQueue::Ticket>>> a, b;
  absl::Cleanup end_waits = [&] { give_up = true; };  // before the futures wait for their calls
  auto a1 = q.AdmitNow(0, "A");
  auto a2 = q.AdmitNow(0, "A");
  ASSERT_TRUE(a1.ok() && a2.ok());
  for (int i = 0; i < 4; ++i) a.push_back(q.AdmitQueued(0, &give_up, "A"));
  ASSERT_EQ(q.queue().queued(), 4);
  EXPECT_EQ(q.AdmitNow(0, "A").status().code(), absl::StatusCode::kResourceExhausted);

  for (int k = 0; k < 3; ++k) {
    b.push_back(q.AdmitAsync(absl::InfiniteFuture(), &give_up, 0, "B"));
    ASSERT_EQ(a[3 - k].wait_for(std::chrono::seconds(10)), std::future_status::ready) << k;
    const absl::Status displaced = a[3 - k].get().status();
    EXPECT_EQ(displaced.code(), absl::StatusCode::kResourceExhausted);
    EXPECT_THAT(displaced.message(), HasSubstr("went to a call of another client host"));
  }
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 4; }));
  const auto even = q.AdmitNow(0, "B");
  EXPECT_EQ(even.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(even.status().message(), Not(HasSubstr("another client host")));
  EXPECT_FALSE(Ready(a[0]) || Ready(b[0]) || Ready(b[1]) || Ready(b[2]));

  // The next slot goes to B (never served), the one after to A.
  { auto release = std::move(*a1); }
  ASSERT_EQ(b[0].wait_for(std::chrono::seconds(10)), std::future_status::ready);
  const auto b_runs = b[0].get();
  EXPECT_TRUE(b_runs.ok());
  EXPECT_FALSE(Ready(a[0]));
  { auto release = std::move(*a2); }
  ASSERT_EQ(a[0].wait_for(std::chrono::seconds(10)), std::future_status::ready);
  const auto a_runs = a[0].get();
  EXPECT_TRUE(a_runs.ok());
  EXPECT_FALSE(Ready(b[1]));
}

// A call whose turn came while a slot was free but not its memory keeps its turn: a host that
// arrives later (never served, so otherwise first) does not take the memory it waits for.
TEST(AdmissionQueue, ACallWaitingForMemoryKeepsItsTurnAgainstHostsThatArriveLater) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  auto a1 = q.AdmitNow(300, "A");
  auto a2 = q.AdmitNow(300, "A");
  auto c = q.AdmitNow(100, "C");
  ASSERT_TRUE(a1.ok() && a2.ok() && c.ok());
  auto large = q.AdmitQueued(800, nullptr, "A");
  { auto release = std::move(*a1); }  // 400 reserved: its turn, a free slot, not its memory
  auto small = q.AdmitQueued(100, nullptr, "B");
  { auto release = std::move(*c); }  // 300 reserved: the small one would fit, the large not
  EXPECT_FALSE(Ready(small));
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 300u);
  { auto release = std::move(*a2); }
  auto large_slot = large.get();
  auto small_slot = small.get();
  ASSERT_TRUE(large_slot.ok() && small_slot.ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 900u);
}

// The call whose turn it is needs memory that no running job holds, only a call waiting behind it
// (its uploaded data): that call goes first, then the large one. Keeping the turn would leave
// both waiting for each other.
TEST(AdmissionQueue, ACallOnlyTheWaitingCallsCanMakeRoomForLetsThemGoFirst) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  auto large = q.queue().Admit("B", 950, 50, absl::InfiniteFuture(), [] { return false; });
  auto small = q.queue().Admit("A", 300, 100, absl::InfiniteFuture(), [] { return false; });
  ASSERT_TRUE(large.ok() && small.ok());
  std::atomic<bool> give_up{false};  // so that a failed test ends instead of waiting forever
  const auto given_up = [&] { return give_up.load(); };
  auto large_runs = std::async(std::launch::async, [&] { return large->TakeSlot(given_up); });
  absl::Cleanup end_large = [&] { give_up = true; };  // before the future waits for its call
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  auto small_runs = std::async(std::launch::async, [&] { return small->TakeSlot(given_up); });
  absl::Cleanup end_small = [&] { give_up = true; };
  ASSERT_EQ(small_runs.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_TRUE(small_runs.get().ok());
  EXPECT_FALSE(Ready(large_runs));  // 900 more do not fit beside the running 300
  { auto done = std::move(*small); }
  ASSERT_EQ(large_runs.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_TRUE(large_runs.get().ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 950u);
}

TEST(AdmissionQueue, ExpectedWaitIsTheRunningMeanHoldTimePerSlotTimesThePosition) {
  QueueUnderTest q(/*max_concurrent=*/2, /*max_queued=*/4);
  EXPECT_EQ(q.queue().ExpectedWaitSeconds(), 0);  // nothing measured yet
  {
    auto slot = q.AdmitNow();
    q.Advance(absl::Seconds(10));
  }
  EXPECT_DOUBLE_EQ(q.queue().ExpectedWaitSeconds(), 10.0 / 2);  // first sample is the mean
  {
    auto slot = q.AdmitNow();
    q.Advance(absl::Seconds(20));
  }
  // Exponential mean with weight 0.3: 0.7 * 10 + 0.3 * 20 = 13 s; a new call is first in line.
  EXPECT_DOUBLE_EQ(q.queue().ExpectedWaitSeconds(), 13.0 / 2);

  auto a = q.AdmitNow(), b = q.AdmitNow();
  auto waiting = q.AdmitAsync();
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  EXPECT_DOUBLE_EQ(q.queue().ExpectedWaitSeconds(), 2 * 13.0 / 2);  // one ahead, then itself
  { auto release = std::move(*a); }
  EXPECT_TRUE(waiting.get().ok());
}

TEST(AdmissionQueue, FailsFastWhenTheExpectedWaitExceedsTheDeadline) {
  QueueUnderTest q(1, 4);
  {
    auto slot = q.AdmitNow();
    q.Advance(absl::Seconds(10));
  }
  auto running = q.AdmitNow();
  ASSERT_TRUE(running.ok());

  auto refused = q.queue().Admit("host", 0, 0, q.now() + absl::Seconds(5), [] { return false; });
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(refused.status().message(), HasSubstr("expected wait 10 s exceeds the deadline 5 s"));
  EXPECT_EQ(q.Metric("scanprep_jobs_rejected_total{reason=\"deadline\"}"), 1);
  EXPECT_EQ(q.queue().queued(), 0);

  // With room in the deadline the call queues; when it is cancelled it leaves the queue.
  std::atomic<bool> cancelled{false};
  auto patient = q.AdmitAsync(q.now() + absl::Seconds(30), &cancelled);
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  cancelled = true;
  EXPECT_EQ(patient.get().status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(q.queue().queued(), 0);
  EXPECT_EQ(q.queue().in_flight(), 1);
}

// A drain refuses new calls; a call already admitted was sent to this replica and may hold its
// data, so it still gets its slot (within the server's grace period).
TEST(AdmissionQueue, DrainingRefusesNewCallsAndLetsAdmittedOnesRun) {
  QueueUnderTest q(1, 2);
  auto running = q.AdmitNow();
  auto waiting = q.AdmitAsync();
  ASSERT_TRUE(Eventually([&] { return q.queue().queued() == 1; }));
  q.queue().Drain();
  const auto refused = q.AdmitNow();
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(refused.status().message(), HasSubstr("draining"));
  EXPECT_EQ(q.Metric("scanprep_jobs_rejected_total{reason=\"draining\"}"), 1);
  EXPECT_FALSE(Ready(waiting));
  { auto release = std::move(*running); }
  EXPECT_TRUE(waiting.get().ok());
  EXPECT_EQ(q.queue().in_flight(), 0);
}

// --- Through the service -------------------------------------------------------------------

// Holds each job whose id starts with "held" in its slot until the test releases it or the call
// is cancelled (ServerOptions::on_slot), so slots are kept busy without timing.
class SlotGate {
 public:
  server::SlotHook Hook() {
    return [this](std::string_view id, const std::function<bool()>& cancelled) {
      if (!id.starts_with("held")) return;
      std::unique_lock lock(mu_);
      holding_.insert(std::string(id));
      changed_.notify_all();
      while (!released_.contains(std::string(id)) && !cancelled()) {
        changed_.wait_for(lock, std::chrono::milliseconds(5));
      }
      holding_.erase(std::string(id));
    };
  }
  // True once job `id` holds its slot (at most 10 s).
  bool WaitUntilHolding(const std::string& id) {
    std::unique_lock lock(mu_);
    return changed_.wait_for(lock, std::chrono::seconds(10), [&] { return holding_.contains(id); });
  }
  void Release(const std::string& id) {
    std::lock_guard lock(mu_);
    released_.insert(id);
    changed_.notify_all();
  }

 private:
  std::mutex mu_;
  std::condition_variable changed_;
  std::set<std::string> holding_, released_;
};

// A Process call that uploaded a whole job and is held by `gate` once it has a slot; Finish()
// lets it run to its end, Cancel() ends it. `forwarded_for`, when set, is sent as
// x-forwarded-for.
class HeldCall {
 public:
  HeldCall(v1::ScanPrep::Stub& stub, SlotGate& gate, const std::string& forwarded_for = "")
      : gate_(gate), id_(absl::StrCat("held-", next_id_++)) {
    if (!forwarded_for.empty()) context_.AddMetadata("x-forwarded-for", forwarded_for);
    stream_ = stub.Process(&context_);
    v1::JobHeader header = SimpleHeader();
    header.set_job_id(id_);
    std::vector<v1::ProcessRequest> requests = {HeaderRequest(header, 100),
                                                ChunkRequest(LineChunk(100))};
    requests.push_back(EndRequest(requests));
    for (const v1::ProcessRequest& r : requests) stream_->Write(r);
    stream_->WritesDone();
  }
  // True once the call holds a slot.
  bool WaitUntilRunning() { return gate_.WaitUntilHolding(id_); }
  grpc::Status Finish() {
    gate_.Release(id_);
    v1::ProcessResponse response;
    while (stream_->Read(&response)) has_report_ |= response.has_report();
    return stream_->Finish();
  }
  void Cancel() {
    context_.TryCancel();
    (void)stream_->Finish();
  }
  bool has_report() const { return has_report_; }

 private:
  static inline std::atomic<int> next_id_{0};
  SlotGate& gate_;
  const std::string id_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ProcessRequest, v1::ProcessResponse>> stream_;
  bool has_report_ = false;
};

// `calls` calls of `host` on a server with one slot: the first runs, the rest queue in order (each
// seen in scanprep_jobs_queued). Fewer are returned when one does not get there.
std::vector<std::unique_ptr<HeldCall>> HoldTheSlotAndQueue(v1::ScanPrep::Stub& stub, SlotGate& gate,
                                                           int metrics, const std::string& host,
                                                           int calls) {
  std::vector<std::unique_ptr<HeldCall>> held;
  for (int c = 0; c < calls; ++c) {
    held.push_back(std::make_unique<HeldCall>(stub, gate, host));
    const bool there = c == 0 ? held.back()->WaitUntilRunning()
                              : WaitForSample(metrics, "scanprep_jobs_queued", c);
    if (!there) {
      held.pop_back();
      break;
    }
  }
  return held;
}

grpc::Status SmallJob(v1::ScanPrep::Stub& stub, std::optional<absl::Duration> timeout = {}) {
  grpc::ClientContext context;
  if (timeout) context.set_deadline(absl::ToChronoTime(absl::Now() + *timeout));
  auto stream = stub.Process(&context);
  stream->Write(HeaderRequest(SimpleHeader(), 100));
  stream->Write(ChunkRequest(LineChunk(100)));
  stream->Write(EndRequest({ChunkRequest(LineChunk(100))}));
  stream->WritesDone();
  v1::ProcessResponse response;
  while (stream->Read(&response)) {
  }
  return stream->Finish();
}

server::ServerOptions Options(int max_concurrent, int max_queued, SlotGate& gate) {
  server::ServerOptions options;
  options.max_concurrent_jobs = max_concurrent;
  options.max_queued_jobs = max_queued;
  options.metrics_listen = "127.0.0.1:0";
  options.on_slot = gate.Hook();
  return options;
}

TEST(AdmissionQueue, AJobLargerThanTheWholeMemoryCapacityIsRefusedAtOnce) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  // Refused even on an idle server: waiting could never make it fit.
  auto refused = q.AdmitNow(1'001);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(),
              HasSubstr("estimated memory of 0 MiB (1001 bytes, from header.total_points) "
                        "exceeds the server's whole memory capacity of 0 MiB (1000 bytes, "
                        "memory_capacity)"));
  EXPECT_THAT(refused.status().message(), HasSubstr("--memory_capacity"));
  EXPECT_EQ(q.Metric("scanprep_jobs_rejected_total{reason=\"memory\"}"), 1);
  EXPECT_EQ(q.queue().in_flight(), 0);
  // Exactly the capacity fits.
  EXPECT_TRUE(q.AdmitNow(1'000).ok());
}

TEST(AdmissionQueue, ACallWaitsUntilItsBytesAreFreeAndTheReservationsNeverExceedTheCapacity) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  EXPECT_EQ(q.Metric("scanprep_memory_budget_bytes"), 1'000);
  auto a = q.AdmitNow(600);
  auto b = q.AdmitNow(300);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 900u);
  EXPECT_EQ(q.Metric("scanprep_memory_reserved_bytes"), 900);

  // Two slots are free but 500 bytes are not: the call queues.
  auto c = q.AdmitQueued(500);
  EXPECT_FALSE(Ready(c));
  EXPECT_EQ(q.queue().in_flight(), 2);

  { auto release = std::move(*b); }  // 400 free: still 100 short
  EXPECT_EQ(q.queue().queued(), 1);  // a grant would have taken it off the queue already
  EXPECT_FALSE(Ready(c));
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 600u);

  { auto release = std::move(*a); }
  auto granted = c.get();
  ASSERT_TRUE(granted.ok()) << granted.status();
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 500u);
  EXPECT_EQ(q.Metric("scanprep_memory_reserved_bytes"), 500);
  EXPECT_EQ(q.queue().in_flight(), 1);
  { auto release = std::move(*granted); }
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 0u);
  EXPECT_EQ(q.queue().in_flight(), 0);
}

TEST(AdmissionQueue, ALargeJobAtTheHeadIsNotOvertakenBySmallOnesThatWouldFit) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  auto running = q.AdmitNow(600);
  ASSERT_TRUE(running.ok());
  auto large = q.AdmitQueued(800);
  // 600 + 100 would fit, but the 800-byte call came first.
  auto small = q.AdmitQueued(100);
  EXPECT_EQ(q.queue().queued(), 2);
  // The tickets (4 slots + 4 places) fill behind them: the refusal names the memory, not the
  // slots.
  std::vector<std::future<absl::StatusOr<AdmissionQueue::Ticket>>> more;
  for (int i = 0; i < 5; ++i) more.push_back(q.AdmitQueued(100));
  EXPECT_THAT(q.AdmitNow(100).status().message(),
              HasSubstr("1 running, 7 waiting for a slot, 0 uploading, the jobs reserving 0 MiB "
                        "of its 0 MiB memory capacity (memory_capacity); the queue is full"));
  EXPECT_EQ(q.queue().in_flight(), 1);
  EXPECT_FALSE(Ready(small));

  { auto release = std::move(*running); }
  // Three fit now (800 + 100 + 100), in arrival order.
  auto large_slot = large.get();
  auto small_slot = small.get();
  auto third_slot = more[0].get();
  ASSERT_TRUE(large_slot.ok() && small_slot.ok() && third_slot.ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 1'000u);
  EXPECT_EQ(q.queue().queued(), 4);  // the rest wait for 100 more bytes each
}

TEST(AdmissionQueue, WhenTheHeadOfTheQueueLeavesTheCallsBehindItThatFitAreAdmitted) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  auto running = q.AdmitNow(600);
  ASSERT_TRUE(running.ok());
  std::atomic<bool> cancel_large{false};
  auto large = q.AdmitQueued(800, &cancel_large);
  auto small = q.AdmitQueued(100);
  EXPECT_FALSE(Ready(small));
  cancel_large = true;
  EXPECT_EQ(large.get().status().code(), absl::StatusCode::kCancelled);
  auto small_slot = small.get();
  ASSERT_TRUE(small_slot.ok()) << small_slot.status();
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 700u);
}

TEST(AdmissionQueue, AClaimIsReservedAsItsDataArrivesSoTheRestServesOtherCalls) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  // A call that claims 900 bytes but has reserved 100 of them (its data so far).
  auto large = q.queue().Admit("host", 900, 100, absl::InfiniteFuture(), [] { return false; });
  ASSERT_TRUE(large.ok()) << large.status();
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 100u);
  // A 200-byte job runs at once (with 900 reserved at the header it would have queued).
  auto small = q.AdmitNow(200);
  ASSERT_TRUE(small.ok()) << small.status();
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 300u);
  EXPECT_EQ(q.Metric("scanprep_memory_reserved_bytes"), 300);

  // The large call's data arrives: its reservation grows while it fits, then waits for the
  // small job to end.
  EXPECT_TRUE(large->Reserve(500, [] { return false; }).ok());
  EXPECT_EQ(large->reserved_bytes(), 500u);
  auto rest =
      std::async(std::launch::async, [&] { return large->Reserve(900, [] { return false; }); });
  EXPECT_EQ(rest.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 700u);
  { auto release = std::move(*small); }
  EXPECT_TRUE(rest.get().ok());
  EXPECT_EQ(large->reserved_bytes(), 900u);
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 900u);
  // More than the claim reserves the claim, no more.
  EXPECT_TRUE(large->Reserve(5'000, [] { return false; }).ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 900u);
}

TEST(AdmissionQueue, AReservationThatCouldLeaveNoClaimAbleToFinishWaits) {
  QueueUnderTest q(/*max_concurrent=*/4, /*max_queued=*/4, /*memory_capacity=*/1'000);
  auto a = q.queue().Admit("host", 600, 300, absl::InfiniteFuture(), [] { return false; });
  auto c = q.queue().Admit("host", 600, 300, absl::InfiniteFuture(), [] { return false; });
  ASSERT_TRUE(a.ok() && c.ok());
  ASSERT_TRUE(a->Reserve(500, [] { return false; }).ok());  // a needs 100 more, 200 are free
  // 200 more for c fit in the capacity, but then a and c would each wait for the other's bytes
  // forever: c waits instead, a completes its claim and runs.
  auto c_grows =
      std::async(std::launch::async, [&] { return c->Reserve(500, [] { return false; }); });
  EXPECT_EQ(c_grows.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 800u);
  ASSERT_TRUE(a->Reserve(600, [] { return false; }).ok());
  EXPECT_EQ(c_grows.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  { auto done = std::move(*a); }
  EXPECT_TRUE(c_grows.get().ok());
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 500u);
  // A waiting reservation gives up when its call is cancelled.
  auto d = q.queue().Admit("host", 600, 0, absl::InfiniteFuture(), [] { return false; });
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->Reserve(600, [] { return true; }).code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(q.queue().memory_reserved_bytes(), 500u);
}

// A call uploads while the slot is busy (it holds no slot meanwhile) and then waits for it.
TEST(Admission, ACallUploadsThenWaitsForTheSlotAndRunsWhenItFrees) {
  SlotGate gate;
  InProcessServer server(Options(1, 1, gate));
  const int metrics = server.server().metrics_port();
  auto stub = server.Stub();
  HeldCall held(*stub, gate);
  ASSERT_TRUE(held.WaitUntilRunning());

  auto queued = std::async(std::launch::async, [&] { return SmallJob(*stub); });
  ASSERT_TRUE(WaitForSample(metrics, "scanprep_jobs_queued", 1));

  const grpc::Status refused = SmallJob(*stub);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), HasSubstr("the queue is full"));
  EXPECT_FALSE(Ready(queued));

  EXPECT_TRUE(held.Finish().ok());
  EXPECT_TRUE(held.has_report());
  EXPECT_TRUE(queued.get().ok());
  EXPECT_EQ(Sample(metrics, "scanprep_jobs_queued"), 0);
  EXPECT_EQ(Sample(metrics, "scanprep_jobs_in_flight"), 0);
  EXPECT_EQ(Sample(metrics, "scanprep_jobs_rejected_total{reason=\"queue_full\"}"), 1);
  EXPECT_EQ(Sample(metrics, GrpcHandled("Process", "ResourceExhausted")), 1);
}

// Through the service, two MES hosts behind a trusted proxy (the loopback address), told apart
// by x-forwarded-for: with one slot, host A running and queueing two more calls, host B's call
// queued last is the next to run. The control: from an untrusted peer the header is ignored, all
// four calls are one host's, and A's second call runs next.
TEST(Admission, HostsForwardedByATrustedProxyTakeTurnsForTheSlot) {
  for (const bool trusted : {true, false}) {
    SCOPED_TRACE(trusted ? "trusted proxy" : "untrusted peer");
    SlotGate gate;
    server::ServerOptions options = Options(1, 8, gate);
    options.trusted_proxies = *server::ParseCidrList(trusted ? "127.0.0.0/8" : "10.0.0.0/8");
    InProcessServer server(options);
    const int metrics = server.server().metrics_port();
    auto stub = server.Stub();
    const auto a = HoldTheSlotAndQueue(*stub, gate, metrics, "203.0.113.1", 3);
    ASSERT_EQ(a.size(), 3u);
    HeldCall &running = *a[0], &a2 = *a[1], &a3 = *a[2];
    HeldCall b(*stub, gate, "203.0.113.2");
    ASSERT_TRUE(WaitForSample(metrics, "scanprep_jobs_queued", 3));

    HeldCall& next = trusted ? b : a2;
    auto next_runs = std::async(std::launch::async, [&] { return next.WaitUntilRunning(); });
    EXPECT_TRUE(running.Finish().ok());
    EXPECT_EQ(next_runs.wait_for(std::chrono::seconds(10)), std::future_status::ready);
    EXPECT_EQ(Sample(metrics, "scanprep_jobs_queued"), 2);  // the other two still wait
    for (HeldCall* call : {&b, &a2, &a3}) call->Cancel();
    EXPECT_TRUE(next_runs.get());
  }
}

// Issue 39 finding 1 through the server: a host that holds the slot and fills the queue no
// longer refuses a second host QUEUE_FULL; the second host's call takes the first host's newest
// place and runs when the slot frees.
TEST(Admission, ASecondHostGetsAPlaceInAQueueAnotherHostFilled) {
  SlotGate gate;
  server::ServerOptions options = Options(1, 2, gate);
  options.trusted_proxies = *server::ParseCidrList("127.0.0.0/8");
  InProcessServer server(options);
  const int metrics = server.server().metrics_port();
  auto stub = server.Stub();
  const auto a = HoldTheSlotAndQueue(*stub, gate, metrics, "203.0.113.1", 3);
  ASSERT_EQ(a.size(), 3u);
  HeldCall &running = *a[0], &a2 = *a[1], &a3 = *a[2];
  HeldCall b(*stub, gate, "203.0.113.2");
  const grpc::Status displaced = a3.Finish();
  EXPECT_EQ(displaced.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(displaced.error_message(), HasSubstr("went to a call of another client host"));
  EXPECT_TRUE(WaitForSample(metrics, "scanprep_jobs_queued", 2));  // a2, and b once uploaded

  auto b_runs = std::async(std::launch::async, [&] { return b.WaitUntilRunning(); });
  EXPECT_TRUE(running.Finish().ok());
  EXPECT_EQ(b_runs.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_TRUE(b_runs.get());
  for (HeldCall* call : {&b, &a2}) call->Cancel();
}

TEST(Admission, ACallWhoseDeadlineIsShorterThanTheExpectedWaitFailsAtOnce) {
  SlotGate gate;
  InProcessServer server(Options(1, 2, gate));
  auto stub = server.Stub();
  {
    // One job that held its slot for at least a second: the mean job time is >= 1 s.
    HeldCall slow(*stub, gate);
    ASSERT_TRUE(slow.WaitUntilRunning());
    std::this_thread::sleep_for(std::chrono::seconds(1));
    ASSERT_TRUE(slow.Finish().ok());
  }
  HeldCall held(*stub, gate);
  ASSERT_TRUE(held.WaitUntilRunning());
  const grpc::Status status = SmallJob(*stub, absl::Milliseconds(500));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_THAT(status.error_message(), HasSubstr("exceeds the deadline"));
  EXPECT_THAT(status.error_message(), HasSubstr("expected wait"));
  EXPECT_EQ(
      Sample(server.server().metrics_port(), "scanprep_jobs_rejected_total{reason=\"deadline\"}"),
      1);
  EXPECT_TRUE(held.Finish().ok());
}

TEST(Admission, ADeadlineThatPassesInTheQueueIsLoggedAsSuch) {
  std::ostringstream log;
  SlotGate gate;
  server::ServerOptions options = Options(1, 1, gate);
  options.log = &log;
  auto server = std::make_unique<InProcessServer>(options);
  auto stub = server->Stub();
  {
    HeldCall held(*stub, gate);
    ASSERT_TRUE(held.WaitUntilRunning());
    // No job has ended yet, so no expected wait refuses it up front: it waits, and its deadline
    // passes in the queue.
    EXPECT_EQ(SmallJob(*stub, absl::Milliseconds(300)).error_code(),
              grpc::StatusCode::DEADLINE_EXCEEDED);
    // The slot frees only once the server saw the waiting call go.
    ASSERT_TRUE(WaitForSample(server->server().metrics_port(), "scanprep_jobs_queued", 0));
    EXPECT_TRUE(held.Finish().ok());
  }
  server.reset();  // every call logged
  EXPECT_THAT(log.str(), HasSubstr("deadline passed during the wait for a slot"));
  EXPECT_THAT(log.str(), ::testing::Not(HasSubstr("CANCELLED")));
}

// grpc.health.v1.Health/Check for `service` ("" = the whole server), by hand (no generated
// health stubs in Debian): 1 = SERVING, 2 = NOT_SERVING, -1 on error, -5 for NOT_FOUND.
int HealthStatus(const std::string& target, const std::string& service = "") {
  grpc::GenericStub stub(grpc::CreateChannel(target, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  // HealthCheckRequest{service}: field 1, length-delimited (names here are < 128 bytes).
  const std::string encoded =
      service.empty() ? "" : std::string{'\x0a', static_cast<char>(service.size())} + service;
  grpc::Slice slice(encoded);
  grpc::ByteBuffer request(&slice, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) { done.set_value(s); });
  const grpc::Status status = done.get_future().get();
  if (status.error_code() == grpc::StatusCode::NOT_FOUND) return -grpc::StatusCode::NOT_FOUND;
  if (!status.ok()) return -1;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return -1;
  std::string bytes;
  for (const grpc::Slice& s : slices)
    bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  // HealthCheckResponse{status = N}: field 1, varint.
  return bytes.size() == 2 && bytes[0] == 0x08 ? bytes[1] : -1;
}

// Load balancers and Kubernetes probes ask by the service's full name as often as by "".
TEST(Admission, HealthAnswersForTheServerAndByServiceName) {
  SlotGate gate;
  InProcessServer server(Options(1, 1, gate));
  EXPECT_EQ(HealthStatus(server.target()), 1);
  EXPECT_EQ(HealthStatus(server.target(), "scanprep.v1.ScanPrep"), 1);
  EXPECT_EQ(HealthStatus(server.target(), "scanprep.v1.NoSuchService"), -5);
  server.server().Drain();
  EXPECT_EQ(HealthStatus(server.target()), 2);
  EXPECT_EQ(HealthStatus(server.target(), "scanprep.v1.ScanPrep"), 2);
}

TEST(Admission, DrainingReportsNotServingRefusesNewCallsAndFinishesAdmittedOnes) {
  SlotGate gate;
  InProcessServer server(Options(1, 1, gate));
  const int metrics = server.server().metrics_port();
  auto stub = server.Stub();
  EXPECT_EQ(HealthStatus(server.target()), 1);
  HeldCall held(*stub, gate);
  ASSERT_TRUE(held.WaitUntilRunning());
  auto queued = std::async(std::launch::async, [&] { return SmallJob(*stub); });
  ASSERT_TRUE(WaitForSample(metrics, "scanprep_jobs_queued", 1));

  server.server().Drain();
  EXPECT_EQ(HealthStatus(server.target()), 2);
  const grpc::Status refused = SmallJob(*stub);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(refused.error_message(), HasSubstr("retry on another replica"));
  EXPECT_FALSE(Ready(queued));

  EXPECT_TRUE(held.Finish().ok());
  EXPECT_TRUE(held.has_report());
  EXPECT_TRUE(queued.get().ok());  // admitted before the drain: it ran
  EXPECT_EQ(Sample(metrics, "scanprep_jobs_rejected_total{reason=\"draining\"}"), 1);
}

}  // namespace
}  // namespace scanprep::testing
