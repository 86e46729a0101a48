// SPDX-License-Identifier: Apache-2.0
#include "server/service_metrics.h"

#include "absl/status/status.h"

namespace scanprep::server {
namespace {

// 1 ms .. 131 s in 18 doublings: a small scan's stage up to a large job's whole run.
std::vector<double> SecondsBuckets() { return metrics::ExponentialBuckets(0.001, 2, 18); }

const char* ReasonLabel(RejectReason reason) {
  switch (reason) {
    case RejectReason::kQueueFull: return "queue_full";
    case RejectReason::kDeadline: return "deadline";
    case RejectReason::kDraining: return "draining";
    case RejectReason::kLimit: return "limit";
    case RejectReason::kInvalid: return "invalid";
    case RejectReason::kMemory: return "memory";
  }
  return "unknown";
}

constexpr RejectReason kAllReasons[] = {RejectReason::kQueueFull, RejectReason::kDeadline,
                                        RejectReason::kDraining, RejectReason::kLimit,
                                        RejectReason::kInvalid, RejectReason::kMemory};

}  // namespace

ServiceMetrics::ServiceMetrics(metrics::Registry& r)
    : rpcs_started_(r.AddCounter("scanprep_rpcs_started_total", "RPCs started, by method.",
                                 {"method"})),
      rpcs_handled_(r.AddCounter("scanprep_rpcs_handled_total",
                                 "RPCs completed, by method and gRPC status code.",
                                 {"method", "code"})),
      rejected_(r.AddCounter("scanprep_jobs_rejected_total",
                             "Process calls refused before or during upload, by reason.",
                             {"reason"})),
      overruns_(r.AddCounter("scanprep_budget_overruns_total",
                             "Jobs that missed a cycle-time budget, by stage (\"total\" = the "
                             "whole pipeline).",
                             {"stage"})),
      points_received_(r.AddCounter("scanprep_points_received_total",
                                    "Points received in request chunks.")
                           .WithLabels({})),
      points_returned_(r.AddCounter("scanprep_points_returned_total",
                                    "Points sent back in result chunks.")
                           .WithLabels({})),
      bytes_received_(r.AddCounter("scanprep_bytes_received_total",
                                   "Serialized size of the Process request messages received.")
                          .WithLabels({})),
      bytes_sent_(r.AddCounter("scanprep_bytes_sent_total",
                               "Serialized size of the Process response messages sent.")
                      .WithLabels({})),
      in_flight_(r.AddGauge("scanprep_jobs_in_flight",
                            "Jobs holding a slot: uploading, processing or downloading.")
                     .WithLabels({})),
      queued_(r.AddGauge("scanprep_jobs_queued", "Jobs waiting for a slot.").WithLabels({})),
      queue_capacity_(r.AddGauge("scanprep_queue_capacity",
                                 "Jobs that may wait for a slot (max_queued_jobs).")
                          .WithLabels({})),
      budget_(r.AddGauge("scanprep_budget_seconds",
                         "The server's default total cycle-time budget per job; 0 = none.")
                  .WithLabels({})),
      memory_budget_(r.AddGauge("scanprep_memory_budget_bytes",
                                "Memory the running jobs' estimates may reserve (memory_budget).")
                         .WithLabels({})),
      memory_reserved_(r.AddGauge("scanprep_memory_reserved_bytes",
                                  "Estimated memory of the jobs holding a slot.")
                           .WithLabels({})),
      job_duration_(r.AddHistogram("scanprep_job_duration_seconds",
                                   "Pipeline wall time of a processed job (all stages).",
                                   SecondsBuckets())
                        .WithLabels({})),
      stage_duration_(r.AddHistogram("scanprep_stage_duration_seconds",
                                     "Wall time of one stage of a processed job.",
                                     SecondsBuckets(), {"stage"})),
      queue_wait_(r.AddHistogram("scanprep_queue_wait_seconds",
                                 "Time an admitted job waited for a slot (0 when one was free).",
                                 SecondsBuckets())
                      .WithLabels({})) {
  // Series that exist before their first event, so rate() and absent() see them from the start.
  for (RejectReason reason : kAllReasons) rejected_.WithLabels({ReasonLabel(reason)});
  overruns_.WithLabels({"total"});
  metrics::AddProcessMetrics(r);
}

void ServiceMetrics::SetQueueCapacity(int max_queued_jobs) { queue_capacity_.Set(max_queued_jobs); }

void ServiceMetrics::SetMemoryBudget(uint64_t bytes) {
  memory_budget_.Set(static_cast<double>(bytes));
}

void ServiceMetrics::SetMemoryReserved(uint64_t bytes) {
  memory_reserved_.Set(static_cast<double>(bytes));
}

void ServiceMetrics::SetDefaultBudget(double seconds) { budget_.Set(seconds); }

void ServiceMetrics::RpcStarted(const std::string& method) {
  rpcs_started_.WithLabels({method}).Inc();
}

void ServiceMetrics::RpcHandled(const std::string& method, grpc::StatusCode code) {
  // gRPC and absl share the code numbering; absl spells the canonical names.
  rpcs_handled_
      .WithLabels({method, absl::StatusCodeToString(static_cast<absl::StatusCode>(code))})
      .Inc();
}

void ServiceMetrics::Rejected(RejectReason reason) { rejected_.WithLabels({ReasonLabel(reason)}).Inc(); }

void ServiceMetrics::SetAdmissionState(int in_flight, int queued) {
  in_flight_.Set(in_flight);
  queued_.Set(queued);
}

void ServiceMetrics::QueueWait(double seconds) { queue_wait_.Observe(seconds); }

void ServiceMetrics::RequestReceived(uint64_t bytes, uint64_t points) {
  bytes_received_.Inc(static_cast<double>(bytes));
  points_received_.Inc(static_cast<double>(points));
}

void ServiceMetrics::ResponseSent(uint64_t bytes, uint64_t points) {
  bytes_sent_.Inc(static_cast<double>(bytes));
  points_returned_.Inc(static_cast<double>(points));
}

void ServiceMetrics::JobProcessed(const PipelineReport& report) {
  job_duration_.Observe(report.total_seconds);
  for (const StageReport& stage : report.stages) {
    stage_duration_.WithLabels({stage.name}).Observe(stage.seconds);
    if (!stage.budget_met) overruns_.WithLabels({stage.name}).Inc();
  }
  if (!report.budget_met) overruns_.WithLabels({"total"}).Inc();
}

}  // namespace scanprep::server
