// SPDX-License-Identifier: Apache-2.0
// Serves a Registry on GET /metrics over HTTP/1.1, on its own port and one thread.
//
// Event-driven (poll) rather than a thread per connection: with cpp-httplib's worker pool, every
// accepted connection waited for a worker, so 2,000 idle sockets (or 64 sending a byte every
// 0.5 s) queued each scrape behind them until it timed out. Here a connection costs a slot in
// the poll set until it has sent its request and taken its answer, within kExchangeDeadline of
// being accepted however it trickles; at most kMaxConnections are open, and a new one past that
// closes the oldest (the nearest to its deadline anyway), so a flood of idle sockets can delay a
// scrape by one poll round, not turn it away. Each answer closes its connection (no keep-alive):
// a scraper reconnects per scrape, which costs a handshake on the cluster network, and no client
// can hold a connection between requests.
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/metrics/registry.h"

namespace scanprep::metrics {

class HttpExporter {
 public:
  // How long a connection may take from its accept to having sent its request and taken the
  // whole answer (a scrape's request arrives in one segment, its answer is tens of kB).
  static constexpr int kExchangeDeadlineMs = 2'000;
  static constexpr int kMaxConnections = 256;
  // A request header longer than this is refused (431) and its connection closed.
  static constexpr size_t kMaxRequestBytes = 8 * 1024;

  // Binds host:port (port 0 = ephemeral) and starts serving; the registry must outlive this.
  static absl::StatusOr<std::unique_ptr<HttpExporter>> Start(const std::string& host, int port,
                                                             const Registry& registry);
  ~HttpExporter();
  HttpExporter(const HttpExporter&) = delete;
  HttpExporter& operator=(const HttpExporter&) = delete;
  int port() const { return port_; }

 private:
  HttpExporter(const Registry& registry) : registry_(registry) {}
  void Serve();

  const Registry& registry_;
  int listener_ = -1;
  int wake_ = -1;  // eventfd: the destructor's signal to stop
  int port_ = 0;
  std::thread thread_;
};

}  // namespace scanprep::metrics
