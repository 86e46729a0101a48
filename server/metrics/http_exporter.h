// SPDX-License-Identifier: Apache-2.0
// Serves a Registry on GET /metrics over HTTP/1.1, on its own port and one thread.
//
// Event-driven (poll) rather than a thread per connection: with cpp-httplib's worker pool, every
// accepted connection waited for a worker, so 2,000 idle sockets (or 64 sending a byte every
// 0.5 s) queued each scrape behind them until it timed out. Here a connection costs a slot in
// the poll set: it must send its request within kRequestDeadlineMs of being accepted however it
// trickles; at most kMaxConnections are open, and a new one past that closes the oldest still
// reading or waiting (never one being answered), so a flood of idle sockets can delay a scrape
// by one poll round, not turn it away. Each answer closes its connection (no keep-alive): a
// scraper reconnects per scrape, which costs a handshake on the cluster network, and no client
// can hold a connection between requests.
//
// Clients that send a request and never read (issue 39 finding 6: 2,000 of them made scrapes of
// a 1.3 MB body take 4.9-7.4 s, and truncated 2 of 8, because each was rendered its own body and
// held the loop): the body is rendered once per poll round and shared by every answer started
// in it; at most kMaxAnswering answers are written at once (each pins socket buffers), the rest
// wait in arrival order; an answer must be taken within kWriteDeadlineMs, and one whose client
// has taken nothing for kStalledMs gives its place to a waiting request.
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/metrics/registry.h"

namespace scanprep::metrics {

class HttpExporter {
 public:
  // How long a connection may take from its accept to having sent its request (a scrape's
  // request arrives in one segment) and, once its answer started, to taking all of it (a few
  // hundred kB at most: the sensor series are bounded, docs/server.md).
  static constexpr int kRequestDeadlineMs = 2'000;
  static constexpr int kWriteDeadlineMs = 2'000;
  static constexpr int kMaxConnections = 256;
  // Answers being written at once, and how long one may stall while a request waits for its
  // place: a scraper reading over a cluster network never stops for 100 ms mid-answer, a client
  // that never reads stops at once.
  static constexpr int kMaxAnswering = 64;
  static constexpr int kStalledMs = 100;
  // The kernel's send buffer of a connection, fixed: autotuning grows it to megabytes for a
  // client that never reads (a loopback one took 3.9 MB of an answer), so the memory such
  // clients pin is kMaxAnswering times this and their windows, and a large answer stalls
  // instead of vanishing into their buffers. 128 KB in flight still fills a 1 Gbit/s link at 1 ms.
  static constexpr int kSendBufferBytes = 64 * 1024;  // the kernel doubles it
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
