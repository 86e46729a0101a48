// SPDX-License-Identifier: Apache-2.0
// The assembled server: ScanPrep service, health checking and reflection on one listening port,
// plus the Prometheus /metrics endpoint on another. Used by main.cc and by the tests, which
// start it in-process on ephemeral ports.
#pragma once

#include <memory>
#include <ostream>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/admission/admission.h"
#include "server/admission/memory_guard.h"
#include "server/admission/peer_limiter.h"
#include "server/job/job_assembler.h"
#include "server/job/job_runner.h"
#include "server/metrics/http_exporter.h"
#include "server/metrics/registry.h"
#include "server/metrics/service_metrics.h"
#include "server/scanprep_service.h"
#include "server/transport/call_log.h"
#include "server/transport/cidr.h"

namespace scanprep::server {

// How long a client connection lives and how its liveness is checked. A long-lived MES channel
// never re-resolves DNS, so without an age limit it keeps every call on the replicas it first
// reached and never sees those an autoscaler adds: after `max_age` the server sends GOAWAY, the
// client reconnects (re-resolving) and calls in progress get `max_age_grace` to finish. Keepalive
// pings find connections whose peer vanished (a NAT or load balancer dropping idle flows).
struct ConnectionOptions {
  absl::Duration max_age = absl::InfiniteDuration();  // infinite = no limit
  absl::Duration max_age_grace = absl::InfiniteDuration();
  absl::Duration keepalive_time = absl::Hours(2);  // gRPC's default
  absl::Duration keepalive_timeout = absl::Seconds(20);
};

// OK unless a duration is zero or negative; the message names the flag.
absl::Status CheckConnectionOptions(const ConnectionOptions& connection);

struct ServerOptions {
  std::string listen = "0.0.0.0:50051";  // port 0 picks a free port
  std::string metrics_listen;            // HOST:PORT of /metrics; empty = no endpoint
  JobLimits limits;
  int max_concurrent_jobs = 4;
  int max_queued_jobs = 8;
  // The memory capacity: what the jobs holding a slot may reserve together
  // (memory_reservation.h); 0 = DetectMemoryCapacity().
  uint64_t memory_capacity_bytes = 0;
  // Ends a job whose memory crosses its reservation (memory_guard.h); off unless enabled.
  MemoryGuardOptions memory_guard;
  int threads = 0;  // arena threads; 0 = hardware concurrency
  // Process calls one client host may have in progress (queued included); 0 = no cap (the
  // admission queue shares the slots fairly between hosts).
  int max_calls_per_peer = 0;
  // Proxies whose x-forwarded-for names the client host (client_identity.h); empty = none.
  std::vector<Cidr> trusted_proxies;
  StreamTimeouts timeouts;
  // Connection lifetime and liveness; see ConnectionOptions.
  ConnectionOptions connection;
  // The gRPC port's transport security; null = plaintext. The in-process tests keep the
  // default; scanprep-server always sets it and serves plaintext only when asked to.
  std::shared_ptr<grpc::ServerCredentials> credentials;
  // The credentials are TLS's: a port gRPC cannot listen on although it is free is then blamed
  // on the certificate and key.
  bool tls = false;
  std::ostream* log = nullptr;  // where CallLog writes; null = no log
  LogFormat log_format = LogFormat::kText;
  int max_log_lines_per_second = CallLog::kMaxLinesPerSecond;  // beyond: dropped and counted
  SensorMetricsOptions sensor_metrics;  // per-sensor health metrics (sensor_metrics.h)
  ProgressHook on_progress;             // test hook, see ProgressHook
  SlotHook on_slot;                     // test hook, see SlotHook
};

class ScanPrepServer {
 public:
  static absl::StatusOr<std::unique_ptr<ScanPrepServer>> Start(const ServerOptions& options);
  ~ScanPrepServer();

  int port() const { return port_; }
  // The bound /metrics port; 0 when the endpoint is off.
  int metrics_port() const { return exporter_ != nullptr ? exporter_->port() : 0; }
  // Reports NOT_SERVING and refuses new calls with UNAVAILABLE, also those waiting in the queue;
  // calls holding a slot carry on.
  void Drain();
  // Drains, stops accepting connections and lets in-flight calls finish; calls still running
  // after `grace` are cancelled. Returns when all calls ended.
  void Shutdown(absl::Duration grace);
  void Wait() { server_->Wait(); }

 private:
  // `options` with the memory capacity resolved.
  explicit ScanPrepServer(const ServerOptions& options);
  void SetServing(bool serving);

  metrics::Registry registry_;
  ServiceMetrics metrics_;
  CallLog log_;
  PeerLimiter peers_;
  AdmissionQueue admission_;
  JobRunner runner_;
  MemoryGuard guard_;  // after the runner and admission it watches: stops before they go
  ScanPrepService service_;
  std::unique_ptr<metrics::HttpExporter> exporter_;
  std::unique_ptr<grpc::Server> server_;  // declared last: destroyed before what it serves
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace scanprep::server
