// SPDX-License-Identifier: Apache-2.0
// The safety net under admission's estimate: a thread that samples the server's resident memory
// and ends a job in processing once the process holds more than the jobs' reservations plus a
// quarter of kMemoryGuardMarginBytes (memory_reservation.h), so no input, whatever makes its stages
// allocate more than the estimate, takes the container past its limit. The job ends
// RESOURCE_EXHAUSTED with the reason MEMORY_RESERVATION_EXCEEDED, counted in
// scanprep_memory_guard_trips_total.
//
// Which job: the guard sees the process, not the jobs (they share one TBB arena and its threads),
// so with several jobs in processing it ends the one that started processing last, then waits
// until that one has stopped before it ends another. The jobs that started earlier fitted in the
// bound before it came; should an earlier one be the one that keeps growing, it crosses the bound
// again on its own and is ended next. With one job in processing the attribution is exact.
//
// Only jobs in processing are ended: an upload holds its arrays (bounded by its declared size and
// the call's byte limit) and a download one result chunk, while the stages are where an input can
// make the memory grow past its estimate.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "absl/synchronization/notification.h"
#include "server/admission/admission.h"
#include "server/admission/admission_observer.h"
#include "server/job/job_runner.h"
#include "server/transport/call_log.h"

namespace scanprep::server {

struct MemoryGuardOptions {
  // scanprep-server turns it on (--memory_guard, default true). Off in an embedding process (the
  // in-process tests), whose resident memory is not the server's alone.
  bool enabled = false;
  // The process's resident bytes, nullopt when unreadable; ResidentBytes() when empty. A test
  // hook for a process whose memory is not the server's.
  std::function<std::optional<uint64_t>()> resident_bytes;
};

// The process's resident memory from /proc/self/statm; nullopt when unreadable.
std::optional<uint64_t> ResidentBytes();

// Why resident memory does not describe this build's allocations ("AddressSanitizer", whose
// shadow memory and quarantine of freed blocks are resident, "ThreadSanitizer" with its shadow),
// or empty when it does.
std::string SanitizerInResidentMemory();

class MemoryGuard {
 public:
  // Starts the sampling thread when `options.enabled` and the build allows it, and logs either
  // way; reports each job it ends to `observer`. `admission`, `runner`, `observer` and `log` must
  // outlive it.
  MemoryGuard(MemoryGuardOptions options, const AdmissionQueue& admission, JobRunner& runner,
              AdmissionObserver& observer, CallLog& log);
  ~MemoryGuard();
  MemoryGuard(const MemoryGuard&) = delete;
  MemoryGuard& operator=(const MemoryGuard&) = delete;

 private:
  void Watch();
  // One sample: updates the idle baseline, or ends the newest job in processing when the bound is
  // crossed and no job ended before is still stopping.
  void Sample();

  MemoryGuardOptions options_;
  const AdmissionQueue& admission_;
  JobRunner& runner_;
  AdmissionObserver& observer_;
  CallLog& log_;
  std::optional<uint64_t> baseline_;  // resident bytes while no job held a reservation
  std::weak_ptr<RunningJob> ending_;  // the job ended last, until it stopped
  absl::Notification stop_;
  std::thread thread_;  // declared last: started once the rest is in place
};

}  // namespace scanprep::server
