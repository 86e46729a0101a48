// SPDX-License-Identifier: Apache-2.0
// Admission control in front of the processing arena: at most `max_concurrent_jobs` calls hold a
// slot, up to `max_queued_jobs` more wait for one in arrival order, and anything beyond that is
// refused at once. A call is admitted when its header arrives, before the upload: a waiting call
// holds no points, so memory stays bounded by the running jobs, and a full server refuses before
// the client sends anything large.
//
// Each call also reserves its job's estimated memory (memory_budget.h) for as long as it holds a
// slot, and the reservations never exceed `memory_budget_bytes`: a call waits until both a slot
// and its bytes are free. The oldest waiting call is served first even when a smaller one behind
// it would fit, so a large job is not starved; a job whose estimate exceeds the whole budget is
// refused at once.
#pragma once

#include <condition_variable>
#include <functional>
#include <limits>
#include <list>
#include <mutex>
#include <utility>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/service_metrics.h"

namespace scanprep::server {

struct AdmissionOptions {
  int max_concurrent_jobs = 4;
  int max_queued_jobs = 8;
  // Sum of the estimates of the jobs holding a slot; the default is no limit.
  uint64_t memory_budget_bytes = std::numeric_limits<uint64_t>::max();
  // Weight of the newest job in the running mean of slot hold times.
  double mean_weight = 0.3;
  // Time source, replaceable in tests.
  std::function<absl::Time()> now = absl::Now;
};

class AdmissionQueue {
 public:
  AdmissionQueue(AdmissionOptions options, ServiceMetrics& metrics);

  // A held slot; destroying it frees the slot for the next waiting call and feeds its hold time
  // into the mean.
  class Slot {
   public:
    Slot(Slot&& o) noexcept
        : queue_(std::exchange(o.queue_, nullptr)), since_(o.since_), bytes_(o.bytes_) {}
    Slot& operator=(Slot&&) = delete;
    ~Slot();

   private:
    friend class AdmissionQueue;
    Slot(AdmissionQueue* queue, absl::Time since, uint64_t bytes)
        : queue_(queue), since_(since), bytes_(bytes) {}
    AdmissionQueue* queue_;
    absl::Time since_;
    uint64_t bytes_;  // reserved from the memory budget
  };

  // A slot and `bytes` of the memory budget for one call, waiting for them when taken. Fails at
  // once with RESOURCE_EXHAUSTED when `bytes` exceeds the whole budget (JOB_EXCEEDS_MEMORY) or
  // the queue is full (QUEUE_FULL), DEADLINE_EXCEEDED when the expected wait already
  // exceeds `deadline`, UNAVAILABLE while draining (also for calls still waiting when the drain
  // starts), and CANCELLED when `cancelled()` turns true while waiting (polled).
  absl::StatusOr<Slot> Admit(uint64_t bytes, absl::Time deadline,
                             const std::function<bool()>& cancelled);

  // Refuse new calls and release the waiting ones with UNAVAILABLE; slots held stay valid.
  void Drain();

  int max_concurrent_jobs() const { return options_.max_concurrent_jobs; }
  int max_queued_jobs() const { return options_.max_queued_jobs; }
  uint64_t memory_budget_bytes() const { return options_.memory_budget_bytes; }
  uint64_t memory_reserved_bytes() const;
  int in_flight() const;
  int queued() const;
  // Seconds a newly queued call would wait: the calls ahead of it plus itself, each needing a
  // slot to free up, at the running mean hold time shared by all slots. 0 before any call ended.
  double ExpectedWaitSeconds() const;

 private:
  struct Waiter {
    uint64_t bytes = 0;
    bool granted = false;
  };
  void Release(absl::Time since, uint64_t bytes);
  // Whether a call needing `bytes` can take a slot now.
  bool FitsLocked(uint64_t bytes) const;
  // Hands slots to the waiting calls in arrival order while the oldest one fits.
  void GrantLocked();
  double ExpectedWaitLocked() const;
  void PublishLocked();

  AdmissionOptions options_;
  ServiceMetrics& metrics_;
  mutable std::mutex mu_;
  std::condition_variable changed_;
  int in_flight_ = 0;
  uint64_t reserved_bytes_ = 0;
  std::list<Waiter*> waiting_;  // arrival order
  double mean_hold_seconds_ = 0;
  bool have_mean_ = false;
  bool draining_ = false;
};

}  // namespace scanprep::server
