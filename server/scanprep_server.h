// The assembled server: ScanPrep service, health checking and reflection on one listening port.
// Used by main.cc and by the tests, which start it in-process on an ephemeral port.
#pragma once

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/job_assembler.h"
#include "server/job_runner.h"
#include "server/scanprep_service.h"

namespace scanprep::server {

struct ServerOptions {
  std::string listen = "0.0.0.0:50051";  // port 0 picks a free port
  JobLimits limits;
  int max_concurrent_jobs = 4;
  int threads = 0;  // arena threads; 0 = hardware concurrency
};

class ScanPrepServer {
 public:
  static absl::StatusOr<std::unique_ptr<ScanPrepServer>> Start(const ServerOptions& options);
  ~ScanPrepServer();

  int port() const { return port_; }
  // Reports NOT_SERVING, refuses new calls and lets in-flight calls finish; calls still running
  // after `grace` are cancelled. Returns when all calls ended.
  void Shutdown(absl::Duration grace);
  void Wait() { server_->Wait(); }

 private:
  ScanPrepServer(const ServerOptions& options);

  JobRunner runner_;
  ScanPrepService service_;
  std::unique_ptr<grpc::Server> server_;  // declared last: destroyed before what it serves
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace scanprep::server
