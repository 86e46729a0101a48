// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/service_metrics.h"

#include <string_view>

#include "absl/time/clock.h"

#include "scanprep/v1/scanprep.grpc.pb.h"

namespace scanprep::server {
namespace {

const char* ReasonLabel(RejectReason reason) {
  switch (reason) {
    case RejectReason::kQueueFull:
      return "queue_full";
    case RejectReason::kDeadline:
      return "deadline";
    case RejectReason::kDraining:
      return "draining";
    case RejectReason::kLimit:
      return "limit";
    case RejectReason::kInvalid:
      return "invalid";
    case RejectReason::kMemory:
      return "memory";
  }
  return "unknown";
}

const char* PhaseLabel(Phase phase) {
  switch (phase) {
    case Phase::kQueue:
      return "queue";
    case Phase::kUpload:
      return "upload";
    case Phase::kProcessing:
      return "processing";
    case Phase::kDownload:
      return "download";
  }
  return "unknown";
}

// grpc_code as the gRPC ecosystem spells it (Go's codes.Code names), not the C++ enum's.
const char* CodeLabel(grpc::StatusCode code) {
  static constexpr const char* kNames[] = {
      "OK",       "Canceled",       "Unknown",          "InvalidArgument",   "DeadlineExceeded",
      "NotFound", "AlreadyExists",  "PermissionDenied", "ResourceExhausted", "FailedPrecondition",
      "Aborted",  "OutOfRange",     "Unimplemented",    "Internal",          "Unavailable",
      "DataLoss", "Unauthenticated"};
  const int i = static_cast<int>(code);
  return i >= 0 && i < static_cast<int>(std::size(kNames)) ? kNames[i] : "Unknown";
}

constexpr RejectReason kAllReasons[] = {RejectReason::kQueueFull, RejectReason::kDeadline,
                                        RejectReason::kDraining,  RejectReason::kLimit,
                                        RejectReason::kInvalid,   RejectReason::kMemory};
constexpr Phase kAllPhases[] = {Phase::kQueue, Phase::kUpload, Phase::kProcessing,
                                Phase::kDownload};
constexpr const char* kBudgetOutcomes[] = {"met", "missed", "none"};

std::vector<std::string> RpcLabels(const RpcMethod& rpc) {
  return {rpc.type, v1::ScanPrep::service_full_name(), rpc.name};
}

bool IsUnary(const RpcMethod& rpc) { return std::string_view(rpc.type) == "unary"; }

const std::vector<std::string> kRpcLabelNames = {"grpc_type", "grpc_service", "grpc_method"};

}  // namespace

std::vector<double> BudgetBuckets() {
  return {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.75,
          1,     1.25,   1.5,   1.75, 2,     2.5,  3,   3.5, 4,   4.5, 5,   6,
          7,     8,      9,     10,   12.5,  15,   20,  30,  45,  60,  120, 300};
}

ServiceMetrics::RpcFamilies ServiceMetrics::AddRpcFamilies(metrics::Registry& r) {
  return {
      .started =
          r.AddCounter("grpc_server_started_total", "RPCs started on the server.", kRpcLabelNames),
      .handled = r.AddCounter("grpc_server_handled_total",
                              "RPCs completed on the server, regardless of success or failure.",
                              {"grpc_type", "grpc_service", "grpc_method", "grpc_code"}),
      .handling_seconds = r.AddHistogram(
          "grpc_server_handling_seconds",
          "Response latency of RPCs handled by the server: the whole call, queue + upload + "
          "processing + download for Process.",
          BudgetBuckets(), kRpcLabelNames),
      .msg_received = r.AddCounter("grpc_server_msg_received_total",
                                   "Stream messages received on the server.", kRpcLabelNames),
      .msg_sent = r.AddCounter("grpc_server_msg_sent_total", "Stream messages sent by the server.",
                               kRpcLabelNames),
  };
}

ServiceMetrics::ServiceMetrics(metrics::Registry& r, const SensorMetricsOptions& sensors)
    : rpc_(AddRpcFamilies(r)),
      rejected_(r.AddCounter("scanprep_jobs_rejected_total",
                             "Process calls refused before or during upload, by reason.",
                             {"reason"})),
      failed_on_warning_(r.AddCounter(
          "scanprep_jobs_failed_on_warning_total",
          "Jobs failed (FAILED_PRECONDITION) on a warning their options.fail_on named, e.g. "
          "--strict, by the warning's code.",
          {"code"})),
      overruns_(r.AddCounter("scanprep_budget_overruns_total",
                             "Processed jobs whose stage exceeded its cycle-time budget, by stage "
                             "(the whole job: scanprep_job_budget_total{outcome=\"missed\"}).",
                             {"stage"})),
      budget_outcomes_(r.AddCounter("scanprep_job_budget_total",
                                    "Processed jobs by the outcome of their own total budget "
                                    "(the job's, else the server's default): met, missed, none.",
                                    {"outcome"})),
      budget_used_(r.AddHistogram("scanprep_job_budget_used_ratio",
                                  "Processing time of a job with a budget over that budget "
                                  "(above 1 = missed).",
                                  {0.1, 0.25, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 1, 1.05, 1.1,
                                   1.25, 1.5, 2, 3, 5, 10})
                       .WithLabels({})),
      points_received_(
          r.AddCounter("scanprep_points_received_total", "Points received in request chunks.")
              .WithLabels({})),
      points_returned_(
          r.AddCounter("scanprep_points_returned_total", "Points sent back in result chunks.")
              .WithLabels({})),
      bytes_received_(r.AddCounter("scanprep_bytes_received_total",
                                   "Serialized size of the Process request messages received.")
                          .WithLabels({})),
      bytes_sent_(r.AddCounter("scanprep_bytes_sent_total",
                               "Serialized size of the Process response messages sent.")
                      .WithLabels({})),
      in_flight_(
          r.AddGauge("scanprep_jobs_in_flight", "Jobs holding a slot: processing or downloading.")
              .WithLabels({})),
      queued_(r.AddGauge("scanprep_jobs_queued", "Jobs uploaded and waiting for a slot.")
                  .WithLabels({})),
      uploading_(
          r.AddGauge("scanprep_jobs_uploading", "Jobs admitted and uploading (they hold no slot).")
              .WithLabels({})),
      queue_capacity_(r.AddGauge("scanprep_queue_capacity",
                                 "Jobs that may upload or wait for a slot beyond the slots "
                                 "(max_queued_jobs).")
                          .WithLabels({})),
      default_time_budget_(
          r.AddGauge("scanprep_budget_seconds",
                     "The server's default total cycle-time budget per job; 0 = none.")
              .WithLabels({})),
      memory_capacity_(
          r.AddGauge("scanprep_memory_budget_bytes",
                     "Memory the running jobs' estimates may reserve (--memory_capacity).")
              .WithLabels({})),
      memory_reserved_(r.AddGauge("scanprep_memory_reserved_bytes",
                                  "Memory the admitted jobs reserved: their data so far while "
                                  "uploading, their estimate once they hold a slot.")
                           .WithLabels({})),
      memory_guard_trips_(
          r.AddCounter("scanprep_memory_guard_trips_total",
                       "Jobs the memory guard ended because the server's resident memory crossed "
                       "the jobs' reservations plus its margin (MEMORY_RESERVATION_EXCEEDED).")
              .WithLabels({})),
      phase_seconds_(r.AddHistogram("scanprep_phase_seconds",
                                    "Time of one phase of a Process call: queue (wait for a "
                                    "slot), upload, processing (all stages), download.",
                                    BudgetBuckets(), {"phase"})),
      stage_seconds_(r.AddHistogram("scanprep_stage_duration_seconds",
                                    "Wall time of one stage of a processed job.", BudgetBuckets(),
                                    {"stage"})),
      sensors_(r, sensors) {
  r.AddGauge("scanprep_build_info", "Always 1; the server's version as a label.", {"version"})
      .WithLabels({SCANPREP_VERSION})
      .Set(1);
  AddFirstSeries();
  metrics::AddProcessMetrics(r);
}

void ServiceMetrics::AddFirstSeries() {
  for (RejectReason reason : kAllReasons) rejected_.WithLabels({ReasonLabel(reason)});
  for (WarningCode code : StrictWarningCodes()) {
    failed_on_warning_.WithLabels({std::string(WarningCodeName(code))});
  }
  for (Phase phase : kAllPhases) phase_seconds_.WithLabels({PhaseLabel(phase)});
  for (const char* outcome : kBudgetOutcomes) budget_outcomes_.WithLabels({outcome});
  for (const RpcMethod& rpc : {kProcessRpc, kProcessUnaryRpc, kGetInfoRpc}) {
    rpc_.started.WithLabels(RpcLabels(rpc));
    rpc_.handling_seconds.WithLabels(RpcLabels(rpc));
    std::vector<std::string> ok = RpcLabels(rpc);
    ok.push_back(CodeLabel(grpc::StatusCode::OK));
    rpc_.handled.WithLabels(ok);
  }
}

void ServiceMetrics::AdmissionConfigured(int max_queued_jobs, uint64_t memory_capacity_bytes) {
  queue_capacity_.Set(max_queued_jobs);
  memory_capacity_.Set(static_cast<double>(memory_capacity_bytes));
}

void ServiceMetrics::AdmissionChanged(int in_flight, int queued, int uploading,
                                      uint64_t reserved_bytes) {
  in_flight_.Set(in_flight);
  queued_.Set(queued);
  uploading_.Set(uploading);
  memory_reserved_.Set(static_cast<double>(reserved_bytes));
}

void ServiceMetrics::Admitted(double waited_seconds) { PhaseEnded(Phase::kQueue, waited_seconds); }

void ServiceMetrics::Refused(AdmissionRefusal why) {
  switch (why) {
    case AdmissionRefusal::kQueueFull:
      return Rejected(RejectReason::kQueueFull);
    case AdmissionRefusal::kDeadline:
      return Rejected(RejectReason::kDeadline);
    case AdmissionRefusal::kDraining:
      return Rejected(RejectReason::kDraining);
    case AdmissionRefusal::kMemory:
      return Rejected(RejectReason::kMemory);
  }
}

void ServiceMetrics::MemoryGuardTripped() { memory_guard_trips_.Inc(); }

void ServiceMetrics::SetDefaultTimeBudget(double seconds) { default_time_budget_.Set(seconds); }

void ServiceMetrics::RpcStarted(const RpcMethod& rpc) {
  rpc_.started.WithLabels(RpcLabels(rpc)).Inc();
  if (IsUnary(rpc)) rpc_.msg_received.WithLabels(RpcLabels(rpc)).Inc();
}

void ServiceMetrics::RpcHandled(const RpcMethod& rpc, grpc::StatusCode code, double seconds) {
  std::vector<std::string> labels = RpcLabels(rpc);
  rpc_.handling_seconds.WithLabels(labels).Observe(seconds);
  // A unary call's one request and response; streams count theirs as they pass.
  if (IsUnary(rpc) && code == grpc::StatusCode::OK) {
    rpc_.msg_sent.WithLabels(labels).Inc();
  }
  labels.push_back(CodeLabel(code));
  rpc_.handled.WithLabels(labels).Inc();
}

void ServiceMetrics::Rejected(RejectReason reason) {
  rejected_.WithLabels({ReasonLabel(reason)}).Inc();
}

void ServiceMetrics::FailedOnWarning(WarningCode code) {
  failed_on_warning_.WithLabels({std::string(WarningCodeName(code))}).Inc();
}

void ServiceMetrics::PhaseEnded(Phase phase, double seconds) {
  phase_seconds_.WithLabels({PhaseLabel(phase)}).Observe(seconds);
}

void ServiceMetrics::RequestReceived(const RpcMethod& rpc, uint64_t bytes, uint64_t points) {
  rpc_.msg_received.WithLabels(RpcLabels(rpc)).Inc();
  bytes_received_.Inc(static_cast<double>(bytes));
  points_received_.Inc(static_cast<double>(points));
}

void ServiceMetrics::ResponseSent(const RpcMethod& rpc, uint64_t bytes, uint64_t points) {
  rpc_.msg_sent.WithLabels(RpcLabels(rpc)).Inc();
  bytes_sent_.Inc(static_cast<double>(bytes));
  points_returned_.Inc(static_cast<double>(points));
}

void ServiceMetrics::JobProcessed(const PipelineReport& report) {
  PhaseEnded(Phase::kProcessing, report.total_seconds);
  if (report.health) sensors_.Record(*report.health, absl::ToUnixMicros(absl::Now()) * 1e-6);
  for (const StageReport& stage : report.stages) {
    stage_seconds_.WithLabels({stage.name}).Observe(stage.seconds);
    if (!stage.budget_met) overruns_.WithLabels({stage.name}).Inc();
  }
  if (report.budget_seconds <= 0) {
    budget_outcomes_.WithLabels({"none"}).Inc();
    return;
  }
  budget_outcomes_.WithLabels({report.budget_met ? "met" : "missed"}).Inc();
  budget_used_.Observe(report.total_seconds / report.budget_seconds);
}

}  // namespace scanprep::server
