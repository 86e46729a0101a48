// SPDX-License-Identifier: Apache-2.0
// What admission control reports as it decides, for whoever counts it (ServiceMetrics exports it
// as metrics): admission owns the events and knows no metric names, labels or registry.
#pragma once

#include <cstdint>

namespace scanprep::server {

// Why the admission queue refused a call.
enum class AdmissionRefusal { kQueueFull, kDeadline, kDraining, kMemory };

class AdmissionObserver {
 public:
  virtual ~AdmissionObserver() = default;

  // The queue's configuration, once when it is made.
  virtual void AdmissionConfigured(int max_queued_jobs, uint64_t memory_capacity_bytes) = 0;
  // After every change: the calls holding a slot, those waiting for one after their upload and
  // those uploading, and the estimated bytes they reserved together.
  virtual void AdmissionChanged(int in_flight, int queued, int uploading,
                                uint64_t reserved_bytes) = 0;
  // A call got its slot after `waited_seconds` in the queue (0 when one was free at once).
  virtual void Admitted(double waited_seconds) = 0;
  virtual void Refused(AdmissionRefusal why) = 0;
  // The memory guard ended a job that took more than its reservation (memory_guard.h).
  virtual void MemoryGuardTripped() = 0;
};

}  // namespace scanprep::server
