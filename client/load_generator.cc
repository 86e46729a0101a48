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

namespace {

// One run of the load test: the workers' calls and the tally they share.
class LoadRun {
 public:
  LoadRun(const std::shared_ptr<grpc::Channel>& channel, const Job& job, const LoadOptions& options)
      : channel_(channel), job_(job), options_(options), schedule_(options, start_) {}

  LoadResult Run() {
    std::vector<std::thread> workers;
    for (int i = 0; i < options_.concurrency; ++i) workers.emplace_back(&LoadRun::Work, this, i);
    for (std::thread& t : workers) t.join();
    result_.elapsed_seconds = absl::ToDoubleSeconds(absl::Now() - start_);
    return std::move(result_);
  }

 private:
  // What one worker needs for its calls, its own so that no call waits on another's.
  struct Caller {
    Caller(const LoadRun& run, uint64_t index)
        : rng(run.options_.seed + index),
          client(run.channel_),
          call{.timeout = run.options_.call_timeout, .chunk_points = run.options_.chunk_points},
          header(run.job_.header),
          base_id(header.job_id().empty() ? "load" : header.job_id()) {}

    std::mt19937_64 rng;
    std::uniform_real_distribution<double> jitter{0, 1};
    ScanPrepClient client;
    CallOptions call;
    v1::JobHeader header;  // the job's, with each call's own job_id
    std::string base_id;   // of those job ids
  };

  // One worker: calls at the times the schedule hands out until it has none left.
  void Work(uint64_t index) {
    Caller caller(*this, index);
    bool pause = false;
    while (true) {
      if (pause) absl::SleepFor(kPauseAfterError);
      const std::optional<absl::Time> at = schedule_.Next();
      if (!at) break;
      absl::SleepFor(*at - absl::Now());
      pause = Call(caller, *at);
    }
  }

  // One call, scheduled for `at`; returns whether the worker pauses before its
  // next (a failed closed-loop call).
  bool Call(Caller& caller, absl::Time at) {
    const absl::Time begin = absl::Now();
    const bool abort = Claim(caller, at, begin);
    CallCanceller canceller;
    if (abort) {
      caller.call.canceller = &canceller;
      caller.call.progress = [&canceller](const v1::Progress& p) {
        if (p.phase() == v1::Progress::PHASE_UPLOAD) canceller.Cancel();
      };
    }
    absl::StatusOr<ProcessResult> r = CallWithRetries(caller, begin);
    caller.call.canceller = nullptr;
    caller.call.progress = nullptr;
    return Tally(r, abort, absl::ToDoubleSeconds(absl::Now() - begin));
  }

  // The call's job id, and whether it is one of the uploads to abort; counts an open-loop call
  // that started late.
  bool Claim(Caller& caller, absl::Time at, absl::Time begin) {
    std::lock_guard lock(mu_);
    const bool abort = AbortsUpload(next_id_, options_.abort_uploads);
    caller.header.set_job_id(absl::StrCat(caller.base_id, "-", next_id_++));
    if (options_.rate > 0 && begin - at > kLateStart) ++result_.late_starts;
    return abort;
  }

  // The call, sent again after each refusal with RetryInfo (RetryWait) while its deadline
  // allows.
  absl::StatusOr<ProcessResult> CallWithRetries(Caller& caller, absl::Time begin) {
    absl::StatusOr<ProcessResult> r =
        caller.client.Process(caller.header, job_.points, caller.call);
    // The retries share the call's deadline, and their waits count in its latency: both are
    // what a caller lives through.
    const absl::Time deadline =
        options_.call_timeout ? begin + *options_.call_timeout : absl::InfiniteFuture();
    while (!r.ok() && options_.retry) {
      const std::optional<absl::Duration> wait = RetryWait(r.status(), caller.jitter(caller.rng));
      if (!wait || absl::Now() + *wait >= deadline) break;
      absl::SleepFor(*wait);
      {
        std::lock_guard lock(mu_);
        ++result_.retried_refusals;
      }
      CallOptions again = caller.call;
      if (options_.call_timeout) again.timeout = deadline - absl::Now();
      r = caller.client.Process(caller.header, job_.points, again);
    }
    return r;
  }

  // Counts the call's outcome; returns whether the worker pauses before its next call.
  bool Tally(const absl::StatusOr<ProcessResult>& r, bool abort, double seconds) {
    std::lock_guard lock(mu_);
    if (abort && r.status().code() == absl::StatusCode::kCancelled) {
      ++result_.aborted;
      return false;
    }
    if (!r.ok()) {
      ErrorTally& tally = result_.errors[absl::StatusCodeToString(r.status().code())];
      if (tally.count++ == 0)
        tally.example = absl::StrCat(r.status().message(), DetailsText(r.status()));
      return options_.rate <= 0;
    }
    ++result_.jobs_ok;
    result_.retries += r->retries;
    result_.latencies.push_back(seconds);
    if (!r->report.budget_met()) ++result_.budget_misses;
    result_.report_budget_seconds =
        std::max(result_.report_budget_seconds, r->report.budget_seconds());
    return false;
  }

  const std::shared_ptr<grpc::Channel>& channel_;
  const Job& job_;
  const LoadOptions& options_;
  const absl::Time start_ = absl::Now();
  Schedule schedule_;
  std::mutex mu_;  // guards next_id_ and result_
  uint64_t next_id_ = 0;
  LoadResult result_;
};

}  // namespace

LoadResult GenerateLoad(const std::shared_ptr<grpc::Channel>& channel, const Job& job,
                        const LoadOptions& options) {
  return LoadRun(channel, job, options).Run();
}

}  // namespace scanprep::client
