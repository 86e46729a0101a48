// SPDX-License-Identifier: Apache-2.0
// The service's Prometheus metrics: owns the metric families and offers one typed call per event,
// so the protocol and admission code never handles names, labels or buckets.
#pragma once

#include <cstdint>
#include <string>

#include <grpcpp/support/status.h>

#include "core/report.h"
#include "server/metrics/registry.h"

namespace scanprep::server {

// Why a call was refused; the `reason` label of scanprep_jobs_rejected_total.
enum class RejectReason { kQueueFull, kDeadline, kDraining, kLimit, kInvalid, kMemory };

class ServiceMetrics {
 public:
  // Registers every scanprep_* family (and the process metrics) in `registry`, which must
  // outlive this object.
  explicit ServiceMetrics(metrics::Registry& registry);

  // Configuration, exported so alerts can compare against it.
  void SetQueueCapacity(int max_queued_jobs);
  void SetDefaultBudget(double seconds);
  void SetMemoryBudget(uint64_t bytes);

  void RpcStarted(const std::string& method);
  void RpcHandled(const std::string& method, grpc::StatusCode code);
  void Rejected(RejectReason reason);

  // Admission: the current numbers of jobs holding a slot and waiting for one.
  void SetAdmissionState(int in_flight, int queued);
  // The estimated bytes the jobs holding a slot reserved from the memory budget.
  void SetMemoryReserved(uint64_t bytes);
  void QueueWait(double seconds);

  void RequestReceived(uint64_t bytes, uint64_t points);
  void ResponseSent(uint64_t bytes, uint64_t points);
  // A pipeline that ran to its end (successfully): wall time, stage times and budget overruns.
  void JobProcessed(const PipelineReport& report);

 private:
  metrics::Family<metrics::Counter>& rpcs_started_;
  metrics::Family<metrics::Counter>& rpcs_handled_;
  metrics::Family<metrics::Counter>& rejected_;
  metrics::Family<metrics::Counter>& overruns_;
  metrics::Counter& points_received_;
  metrics::Counter& points_returned_;
  metrics::Counter& bytes_received_;
  metrics::Counter& bytes_sent_;
  metrics::Gauge& in_flight_;
  metrics::Gauge& queued_;
  metrics::Gauge& queue_capacity_;
  metrics::Gauge& budget_;
  metrics::Gauge& memory_budget_;
  metrics::Gauge& memory_reserved_;
  metrics::Histogram& job_duration_;
  metrics::Family<metrics::Histogram>& stage_duration_;
  metrics::Histogram& queue_wait_;
};

}  // namespace scanprep::server
