// SPDX-License-Identifier: Apache-2.0
// Serves a Registry on GET /metrics over HTTP (cpp-httplib), on its own port and thread.
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/metrics/registry.h"

namespace httplib {
class Server;
}

namespace scanprep::metrics {

class HttpExporter {
 public:
  // Binds host:port (port 0 = ephemeral) and starts serving; the registry must outlive this.
  static absl::StatusOr<std::unique_ptr<HttpExporter>> Start(const std::string& host, int port,
                                                             const Registry& registry);
  ~HttpExporter();
  int port() const { return port_; }

 private:
  HttpExporter() = default;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  int port_ = 0;
};

}  // namespace scanprep::metrics
