// SPDX-License-Identifier: Apache-2.0
#include "server/scanprep_server.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <thread>

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/notification.h"
#include "core/base/status_macros.h"
#include "server/admission/memory_reservation.h"

namespace scanprep::server {
namespace {

struct HostPort {
  std::string host;
  int port = 0;
};

// "host:port", "[v6]:port"; the port may be 0 (any free port).
absl::StatusOr<HostPort> ParseHostPort(const std::string& text, const std::string& flag) {
  const size_t colon = text.rfind(':');
  HostPort hp;
  if (colon == std::string::npos || colon == 0 ||
      !absl::SimpleAtoi(text.substr(colon + 1), &hp.port) || hp.port < 0 || hp.port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": '", text, "' is not HOST:PORT (port 0..65535)"));
  }
  hp.host = text.substr(0, colon);
  if (hp.host.size() > 2 && hp.host.front() == '[' && hp.host.back() == ']') {
    hp.host = hp.host.substr(1, hp.host.size() - 2);
  }
  return hp;
}

// --metrics_listen ":PORT" takes --listen's host.
absl::StatusOr<HostPort> MetricsAddress(const std::string& metrics_listen,
                                        const std::string& listen) {
  if (!metrics_listen.starts_with(":")) return ParseHostPort(metrics_listen, "metrics_listen");
  SCANPREP_ASSIGN_OR_RETURN(HostPort grpc, ParseHostPort(listen, "listen"));
  SCANPREP_ASSIGN_OR_RETURN(HostPort metrics,
                            ParseHostPort("x" + metrics_listen, "metrics_listen"));
  metrics.host = grpc.host;
  return metrics;
}

// Why gRPC could not listen on `listen`, which it does not say: the address bound by a socket of
// our own tells a port in use or an address this host lacks ("Address already in use"); a free
// address leaves the TLS pair, when there is one.
std::string ListenFailureCause(const std::string& listen, bool tls) {
  auto address = ParseHostPort(listen, "listen");
  if (!address.ok()) return std::string(address.status().message());
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  const std::string host = address->host == "*" ? "" : address->host;
  if (const int e = getaddrinfo(host.empty() ? nullptr : host.c_str(),
                                std::to_string(address->port).c_str(), &hints, &found);
      e != 0) {
    return absl::StrCat("cannot resolve '", address->host, "': ", gai_strerror(e));
  }
  std::string cause;
  const int fd = socket(found->ai_family, found->ai_socktype, found->ai_protocol);
  const int one = 1;
  if (fd >= 0 && (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
                  bind(fd, found->ai_addr, found->ai_addrlen) != 0)) {
    cause = std::strerror(errno);
  }
  if (fd >= 0) close(fd);
  freeaddrinfo(found);
  if (!cause.empty()) return cause;
  return tls ? "the address is free: the TLS certificate and key are probably not a valid pair"
             : "the address is free; gRPC gave no reason";
}

// gRPC reads durations as int milliseconds, INT_MAX meaning "never".
int Millis(absl::Duration d) {
  if (d == absl::InfiniteDuration()) return std::numeric_limits<int>::max();
  return static_cast<int>(
      std::min<int64_t>(absl::ToInt64Milliseconds(d), std::numeric_limits<int>::max()));
}

void AddConnectionArguments(const ConnectionOptions& c, grpc::ServerBuilder& builder) {
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS, Millis(c.max_age));
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS, Millis(c.max_age_grace));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, Millis(c.keepalive_time));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, Millis(c.keepalive_timeout));
  // Clients may ping as often as every 10 s, with or without calls in progress, without being
  // sent GOAWAY "too_many_pings" (gRPC's default minimum is 5 min).
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10'000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
}

}  // namespace

ScanPrepServer::ScanPrepServer(const ServerOptions& options)
    : metrics_(registry_, options.sensor_metrics),
      log_(options.log, options.max_log_lines_per_second, absl::Now, options.log_format),
      peers_(options.max_calls_per_peer),
      admission_({.max_concurrent_jobs = options.max_concurrent_jobs,
                  .max_queued_jobs = options.max_queued_jobs,
                  .memory_capacity_bytes = options.memory_capacity_bytes},
                 metrics_),
      runner_(options.threads, options.on_progress),
      guard_(options.memory_guard, admission_, runner_, metrics_, log_),
      service_(options.limits, options.timeouts, options.trusted_proxies, admission_, runner_,
               metrics_, peers_, log_, options.on_slot) {
  metrics_.SetDefaultTimeBudget(options.limits.default_budget_seconds);
}

absl::Status CheckConnectionOptions(const ConnectionOptions& c) {
  const std::pair<const char*, absl::Duration> durations[] = {
      {"max_connection_age", c.max_age},
      {"max_connection_age_grace", c.max_age_grace},
      {"keepalive_time", c.keepalive_time},
      {"keepalive_timeout", c.keepalive_timeout}};
  for (const auto& [flag, d] : durations) {
    // gRPC counts whole milliseconds; below 1 ms would turn into 0, "immediately".
    if (d < absl::Milliseconds(1)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", flag, " must be at least 1ms (got ", absl::FormatDuration(d), ")"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<ScanPrepServer>> ScanPrepServer::Start(
    const ServerOptions& options) {
  if (options.max_concurrent_jobs < 1) {
    return absl::InvalidArgumentError("max_concurrent_jobs must be at least 1");
  }
  if (options.max_queued_jobs < 0) {
    return absl::InvalidArgumentError("max_queued_jobs must be at least 0");
  }
  if (options.timeouts.header <= absl::ZeroDuration() ||
      options.timeouts.idle <= absl::ZeroDuration()) {
    return absl::InvalidArgumentError("header_timeout and idle_timeout must be positive");
  }
  for (const auto& [name, rate] :
       {std::pair{"min_upload_rate", options.timeouts.min_upload_rate},
        std::pair{"min_download_rate", options.timeouts.min_download_rate}}) {
    if (!(rate >= 0 && rate < 1e12)) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, " must be in [0, 1e12) bytes per second, got ", rate));
    }
  }
  if (options.max_calls_per_peer < 0) {
    return absl::InvalidArgumentError("max_calls_per_peer must be at least 0 (0 = no cap)");
  }
  ServerOptions resolved = options;
  if (resolved.memory_capacity_bytes == 0) {
    SCANPREP_ASSIGN_OR_RETURN(auto capacity, DetectMemoryCapacity());
    resolved.memory_capacity_bytes = capacity.bytes;
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  std::unique_ptr<ScanPrepServer> server(new ScanPrepServer(resolved));
  if (!options.metrics_listen.empty()) {
    SCANPREP_ASSIGN_OR_RETURN(auto address, MetricsAddress(options.metrics_listen, options.listen));
    SCANPREP_ASSIGN_OR_RETURN(
        server->exporter_,
        metrics::HttpExporter::Start(address.host, address.port, server->registry_));
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(
      options.listen,
      options.credentials != nullptr ? options.credentials : grpc::InsecureServerCredentials(),
      &server->port_);
  builder.SetMaxReceiveMessageSize(static_cast<int>(options.limits.max_message_bytes));
  // And sent: a ProcessUnary answer (its points with normals) waits in gRPC's buffers until the
  // client reads it (holding its call's slot and reservation: UnsentAnswers), one message each way.
  builder.SetMaxSendMessageSize(static_cast<int>(options.limits.max_message_bytes));
  // gRPC sets SO_REUSEPORT by default: a second server on the same port would start silently and
  // take half the connections. Without it the second one fails to start.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  AddConnectionArguments(options.connection, builder);
  builder.RegisterService(&server->service_);
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(server->service_.unsent_answers().InterceptorFactory());
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || server->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", options.listen, " (",
                                               ListenFailureCause(options.listen, options.tls),
                                               ")"));
  }
  server->SetServing(true);
  return server;
}

// Health answers for the whole server ("") and by the service's full name, as probes ask either.
void ScanPrepServer::SetServing(bool serving) {
  grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService();
  health->SetServingStatus(serving);
  health->SetServingStatus(scanprep::v1::ScanPrep::service_full_name(), serving);
}

void ScanPrepServer::Drain() {
  SetServing(false);
  admission_.Drain();
}

void ScanPrepServer::Shutdown(absl::Duration grace) {
  if (shut_down_) return;
  shut_down_ = true;
  Drain();
  // At the end of the grace period the jobs are cancelled through their tokens, so the pipeline
  // stops without waiting for an RPC thread to notice. gRPC cancels the calls themselves once a
  // cancelled stage has had its 0.2 s to stop, so a processing call ends with the handler's
  // status naming the shutdown rather than gRPC's own.
  const absl::Time end = absl::Now() + grace;
  absl::Notification finished;
  std::thread canceller([&] {
    if (!finished.WaitForNotificationWithDeadline(end)) runner_.CancelAll();
  });
  server_->Shutdown(absl::ToChronoTime(end + absl::Milliseconds(300)));
  finished.Notify();
  canceller.join();
}

ScanPrepServer::~ScanPrepServer() {
  if (server_ != nullptr) Shutdown(absl::ZeroDuration());
}

}  // namespace scanprep::server
