#include "server/scanprep_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/str_cat.h"

namespace scanprep::server {

ScanPrepServer::ScanPrepServer(const ServerOptions& options)
    : runner_(options.threads, options.max_concurrent_jobs), service_(options.limits, runner_) {}

absl::StatusOr<std::unique_ptr<ScanPrepServer>> ScanPrepServer::Start(
    const ServerOptions& options) {
  if (options.max_concurrent_jobs < 1) {
    return absl::InvalidArgumentError("max_concurrent_jobs must be at least 1");
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  std::unique_ptr<ScanPrepServer> server(new ScanPrepServer(options));
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, grpc::InsecureServerCredentials(), &server->port_);
  builder.RegisterService(&server->service_);
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || server->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", options.listen));
  }
  server->server_->GetHealthCheckService()->SetServingStatus(true);
  return server;
}

void ScanPrepServer::Shutdown(absl::Duration grace) {
  if (shut_down_) return;
  shut_down_ = true;
  server_->GetHealthCheckService()->SetServingStatus(false);
  server_->Shutdown(absl::ToChronoTime(absl::Now() + grace));
}

ScanPrepServer::~ScanPrepServer() {
  if (server_ != nullptr) Shutdown(absl::ZeroDuration());
}

}  // namespace scanprep::server
