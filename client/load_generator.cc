// SPDX-License-Identifier: Apache-2.0
#include "client/load_generator.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/call_error.h"
#include "client/scanprep_client.h"

namespace scanprep::client {
namespace {

// Hands each worker the time its next call should start, or nothing when the run is over.
class Schedule {
 public:
  Schedule(const LoadOptions& options, absl::Time start)
      : options_(options), end_(start + options.duration), next_(start), rng_(options.seed) {}

  std::optional<absl::Time> Next() {
    std::lock_guard lock(mu_);
    const absl::Time now = absl::Now();
    if (now >= end_ || (options_.max_jobs && claimed_ >= *options_.max_jobs)) return std::nullopt;
    if (options_.rate <= 0) {
      ++claimed_;
      return now;
    }
    const absl::Time at = next_;
    if (at >= end_) return std::nullopt;
    ++claimed_;
    next_ +=
        absl::Seconds(options_.arrivals == Arrivals::kFixed ? 1 / options_.rate : interval_(rng_));
    return at;
  }

 private:
  const LoadOptions& options_;
  const absl::Time end_;
  std::mutex mu_;
  absl::Time next_;
  uint64_t claimed_ = 0;
  std::mt19937_64 rng_;
  std::exponential_distribution<double> interval_{options_.rate > 0 ? options_.rate : 1};
};

// Whether call `index` is one of the `share` to abort: spread evenly, so every run of 1/share
// calls holds one.
bool AbortsUpload(uint64_t index, double share) {
  return std::floor((index + 1) * share) > std::floor(index * share);
}

}  // namespace

std::optional<absl::Duration> RetryWait(const absl::Status& status, double jitter) {
  if (status.code() != absl::StatusCode::kResourceExhausted &&
      status.code() != absl::StatusCode::kUnavailable) {
    return std::nullopt;
  }
  const std::optional<absl::Duration> delay = DetailsOf(status).retry_delay;
  if (!delay) return std::nullopt;
  return std::max(kPauseAfterError, std::min(*delay, kMaxRetryWait) * (1 + jitter / 4));
}

uint64_t LoadResult::error_count() const {
  uint64_t n = 0;
  for (const auto& [code, tally] : errors) n += tally.count;
  return n;
}

LoadResult GenerateLoad(const std::shared_ptr<grpc::Channel>& channel, const Job& job,
                        const LoadOptions& options) {
  LoadResult result;
  std::mutex mu;  // guards result
  const absl::Time start = absl::Now();
  Schedule schedule(options, start);
  uint64_t next_id = 0;

  auto worker = [&](uint64_t index) {
    std::mt19937_64 rng(options.seed + index);
    std::uniform_real_distribution<double> jitter(0, 1);
    ScanPrepClient client(channel);
    CallOptions call{.timeout = options.call_timeout, .chunk_points = options.chunk_points};
    v1::JobHeader header = job.header;
    const std::string base_id = header.job_id().empty() ? "load" : header.job_id();
    bool pause = false;
    while (true) {
      if (pause) absl::SleepFor(kPauseAfterError);
      pause = false;
      const std::optional<absl::Time> at = schedule.Next();
      if (!at) break;
      absl::SleepFor(*at - absl::Now());
      const absl::Time begin = absl::Now();
      bool abort = false;
      {
        std::lock_guard lock(mu);
        abort = AbortsUpload(next_id, options.abort_uploads);
        header.set_job_id(absl::StrCat(base_id, "-", next_id++));
        if (options.rate > 0 && begin - *at > kLateStart) ++result.late_starts;
      }
      CallCanceller canceller;
      if (abort) {
        call.canceller = &canceller;
        call.progress = [&canceller](const v1::Progress& p) {
          if (p.phase() == v1::Progress::PHASE_UPLOAD) canceller.Cancel();
        };
      }
      absl::StatusOr<ProcessResult> r = client.Process(header, job.points, call);
      // The retries share the call's deadline, and their waits count in its latency: both are
      // what a caller lives through.
      const absl::Time deadline =
          options.call_timeout ? begin + *options.call_timeout : absl::InfiniteFuture();
      while (!r.ok() && options.retry) {
        const std::optional<absl::Duration> wait = RetryWait(r.status(), jitter(rng));
        if (!wait || absl::Now() + *wait >= deadline) break;
        absl::SleepFor(*wait);
        {
          std::lock_guard lock(mu);
          ++result.retried_refusals;
        }
        CallOptions again = call;
        if (options.call_timeout) again.timeout = deadline - absl::Now();
        r = client.Process(header, job.points, again);
      }
      call.canceller = nullptr;
      call.progress = nullptr;
      const double seconds = absl::ToDoubleSeconds(absl::Now() - begin);
      std::lock_guard lock(mu);
      if (abort && r.status().code() == absl::StatusCode::kCancelled) {
        ++result.aborted;
        continue;
      }
      if (!r.ok()) {
        ErrorTally& tally = result.errors[absl::StatusCodeToString(r.status().code())];
        if (tally.count++ == 0)
          tally.example = absl::StrCat(r.status().message(), DetailsText(r.status()));
        pause = options.rate <= 0;
        continue;
      }
      ++result.jobs_ok;
      result.retries += r->retries;
      result.latencies.push_back(seconds);
      if (!r->report.budget_met()) ++result.budget_misses;
      result.report_budget_seconds =
          std::max(result.report_budget_seconds, r->report.budget_seconds());
    }
  };
  std::vector<std::thread> workers;
  for (int i = 0; i < options.concurrency; ++i) workers.emplace_back(worker, i);
  for (std::thread& t : workers) t.join();
  result.elapsed_seconds = absl::ToDoubleSeconds(absl::Now() - start);
  return result;
}

}  // namespace scanprep::client
