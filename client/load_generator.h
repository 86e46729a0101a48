// SPDX-License-Identifier: Apache-2.0
// The engine of `scanprep load`: replays one job over a shared channel from `concurrency`
// workers, closed loop (each worker calls back to back) or open loop (arrivals at a total rate,
// at most `concurrency` in flight), and tallies what came back.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "client/job_builder.h"
#include "client/scanprep_client.h"

namespace scanprep::client {

enum class Arrivals { kPoisson, kFixed };

struct LoadOptions {
  int concurrency = 1;
  absl::Duration duration = absl::Seconds(60);  // no call starts after this
  std::optional<uint64_t> max_jobs;             // no call starts after this many
  double rate = 0;                              // jobs/s over all workers; 0 = closed loop
  Arrivals arrivals = Arrivals::kPoisson;
  std::optional<absl::Duration> call_timeout;
  uint64_t seed = 1;  // of the Poisson arrivals
  // Share of calls, spread evenly, that the client cancels as soon as the server confirmed its
  // first chunk: proves the server frees what an aborted upload held.
  double abort_uploads = 0;
  size_t chunk_points = kDefaultChunkPoints;  // points per upload message
  // A call refused with RESOURCE_EXHAUSTED or UNAVAILABLE and a RetryInfo is sent again after
  // the delay the server asked for (RetryWait), as a well-behaved client would, rather than
  // counted as an error, within the call's `call_timeout` from its first attempt (past
  // `duration`, which only stops new calls).
  bool retry = true;
};

struct ErrorTally {
  uint64_t count = 0;
  std::string example;  // the first message seen with this code
};

struct LoadResult {
  double elapsed_seconds = 0;  // from the first start until the last call ended
  uint64_t jobs_ok = 0;
  std::vector<double> latencies;             // seconds per successful call, whole call
  std::map<std::string, ErrorTally> errors;  // by status code name, e.g. "UNAVAILABLE"
  uint64_t budget_misses = 0;                // successful calls with Report.budget_met false
  double report_budget_seconds = 0;          // largest Report.budget_seconds seen (0 = none)
  uint64_t late_starts = 0;                  // open loop: started > kLateStart after schedule
  uint64_t aborted = 0;                      // --abort_uploads calls that ended CANCELLED, as meant
  uint64_t retries = 0;  // attempts that ended UNAVAILABLE and were sent again (CallOptions)
  uint64_t retried_refusals = 0;  // refusals with RetryInfo waited out and sent again (retry)

  uint64_t error_count() const;
};

// An open-loop call that starts this much after its scheduled time waited for a free worker
// (thread wake-up jitter is far below it): the in-flight bound, not the rate, set the pace.
inline constexpr absl::Duration kLateStart = absl::Milliseconds(10);

// A closed-loop worker waits this long after a failed call: a server that refuses at once would
// otherwise be flooded with thousands of calls a second, which measures nothing.
inline constexpr absl::Duration kPauseAfterError = absl::Milliseconds(100);

// The longest a worker waits on one RetryInfo: a server's delay is its guess at when a place
// frees up, and a load test that slept minutes on one would measure nothing.
inline constexpr absl::Duration kMaxRetryWait = absl::Seconds(10);

// How long to wait before sending a refused call again, or nothing when it is not to be sent
// again: RESOURCE_EXHAUSTED or UNAVAILABLE with a RetryInfo, its delay capped at kMaxRetryWait,
// at least kPauseAfterError, and stretched by `jitter` (from [0, 1): up to a quarter longer), so
// that workers refused together do not all come back together.
std::optional<absl::Duration> RetryWait(const absl::Status& status, double jitter);

// Replays `job` as `options` say until no call is left to start and every call has ended.
LoadResult GenerateLoad(const std::shared_ptr<grpc::Channel>& channel, const Job& job,
                        const LoadOptions& options);

}  // namespace scanprep::client
