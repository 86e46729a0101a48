// SPDX-License-Identifier: Apache-2.0
// The service's Prometheus metrics: owns the metric families and offers one typed call per event,
// so the protocol code never handles names, labels or buckets; admission reports through its own
// AdmissionObserver, which this implements.
//
// RPCs are counted under the gRPC ecosystem's names and labels (grpc_server_handled_total
// {grpc_type, grpc_service, grpc_method, grpc_code} etc., as go-grpc-prometheus and
// grpc-ecosystem's Java/Python interceptors export them), so stock gRPC dashboards and alerts work.
#pragma once

#include <cstdint>
#include <string>

#include <grpcpp/support/status.h>

#include "core/stages/report.h"
#include "core/stages/warning.h"
#include "server/admission/admission_observer.h"
#include "server/metrics/registry.h"
#include "server/metrics/sensor_metrics.h"

namespace scanprep::server {

// Why a call was refused, by admission (AdmissionRefusal, which Refused maps) or by the service
// (kLimit, kInvalid); the `reason` label of scanprep_jobs_rejected_total.
enum class RejectReason { kQueueFull, kDeadline, kDraining, kLimit, kInvalid, kMemory };

// The `phase` label of scanprep_phase_seconds: where a job's time on the line goes.
enum class Phase { kQueue, kUpload, kProcessing, kDownload };

// One RPC method as the grpc_server_* metrics label it.
struct RpcMethod {
  const char* type;  // grpc_type: "unary", "client_stream", "server_stream" or "bidi_stream"
  const char* name;  // grpc_method
};
inline constexpr RpcMethod kProcessRpc{"bidi_stream", "Process"};
inline constexpr RpcMethod kProcessUnaryRpc{"unary", "ProcessUnary"};
inline constexpr RpcMethod kGetInfoRpc{"unary", "GetInfo"};

// Histogram bounds in seconds, fine where cycle-time budgets lie (0.5 s to 10 s in steps of
// 0.25 s to 1 s, so a 3 s budget and a 4 s one fall in different buckets), coarse outside.
std::vector<double> BudgetBuckets();

class ServiceMetrics : public AdmissionObserver {
 public:
  // Registers every family (and the process metrics, and the per-sensor ones) in `registry`,
  // which must outlive this object.
  explicit ServiceMetrics(metrics::Registry& registry, const SensorMetricsOptions& sensors = {});

  // Configuration, exported so alerts can compare against it.
  void SetDefaultTimeBudget(double seconds);

  void RpcStarted(const RpcMethod& rpc);
  // `seconds`: from the call's start to its status.
  void RpcHandled(const RpcMethod& rpc, grpc::StatusCode code, double seconds);
  void Rejected(RejectReason reason);
  // A job that ended FAILED_PRECONDITION on a warning its options.fail_on (strict) named, by the
  // warning's code: a plant sees how many parts strict stopped, and why.
  void FailedOnWarning(WarningCode code);

  // Admission's events: the queue's capacity and the memory capacity (exported so alerts can
  // compare against them), the jobs holding a slot and waiting for one with the bytes they
  // reserved, the queue phase (also a zero wait for a free slot), refusals and memory guard trips.
  void AdmissionConfigured(int max_queued_jobs, uint64_t memory_capacity_bytes) override;
  void AdmissionChanged(int in_flight, int queued, int uploading, uint64_t reserved_bytes) override;
  void Admitted(double waited_seconds) override;
  void Refused(AdmissionRefusal why) override;
  void MemoryGuardTripped() override;
  // A phase of a Process call that ended.
  void PhaseEnded(Phase phase, double seconds);

  // One request message of a job call received, one response message sent (a ProcessUnary
  // call's are its pieces, as the stream it is run as).
  void RequestReceived(const RpcMethod& rpc, uint64_t bytes, uint64_t points);
  void ResponseSent(const RpcMethod& rpc, uint64_t bytes, uint64_t points);
  // A pipeline that ran to its end (successfully): its time (phase "processing"), stage times,
  // stage overruns, the job's budget outcome with its used share of the budget, and its health
  // per sensor (SensorMetrics) when it ran the health stage.
  void JobProcessed(const PipelineReport& report);

 private:
  // The grpc_server_* families, labelled by RpcMethod (handled also by grpc_code).
  struct RpcFamilies {
    metrics::Family<metrics::Counter>& started;
    metrics::Family<metrics::Counter>& handled;
    metrics::Family<metrics::Histogram>& handling_seconds;
    metrics::Family<metrics::Counter>& msg_received;
    metrics::Family<metrics::Counter>& msg_sent;
  };
  static RpcFamilies AddRpcFamilies(metrics::Registry& r);
  // The series that exist before their first event, so rate() and absent() see them from the
  // start.
  void AddFirstSeries();

  RpcFamilies rpc_;
  metrics::Family<metrics::Counter>& rejected_;
  metrics::Family<metrics::Counter>& failed_on_warning_;
  metrics::Family<metrics::Counter>& overruns_;
  metrics::Family<metrics::Counter>& budget_outcomes_;
  metrics::Histogram& budget_used_;
  metrics::Counter& points_received_;
  metrics::Counter& points_returned_;
  metrics::Counter& bytes_received_;
  metrics::Counter& bytes_sent_;
  metrics::Gauge& in_flight_;
  metrics::Gauge& queued_;
  metrics::Gauge& uploading_;
  metrics::Gauge& queue_capacity_;
  metrics::Gauge& default_time_budget_;
  metrics::Gauge& memory_capacity_;  // exported under its older name, scanprep_memory_budget_bytes
  metrics::Gauge& memory_reserved_;
  metrics::Counter& memory_guard_trips_;
  metrics::Family<metrics::Histogram>& phase_seconds_;
  metrics::Family<metrics::Histogram>& stage_seconds_;
  SensorMetrics sensors_;
};

}  // namespace scanprep::server
