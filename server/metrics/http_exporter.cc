// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/http_exporter.h"

#include <httplib.h>

#include "absl/strings/str_cat.h"

namespace scanprep::metrics {
namespace {

// A scrape's request arrives in one segment and its answer is small, so a second per read or
// write is generous; a client that sends a partial header and stops loses its worker after that.
// More workers than httplib's default 8: eight slow-header clients held every worker for the
// default 5 s read timeout, and every scrape waited behind them.
constexpr int kIoTimeoutSeconds = 1;
constexpr size_t kWorkers = 16;

}  // namespace

absl::StatusOr<std::unique_ptr<HttpExporter>> HttpExporter::Start(const std::string& host, int port,
                                                                  const Registry& registry) {
  std::unique_ptr<HttpExporter> exporter(new HttpExporter());
  exporter->server_ = std::make_unique<httplib::Server>();
  // httplib's default sets SO_REUSEPORT, with which a second server on the same port starts
  // silently and takes half the scrapes; SO_REUSEADDR only allows a restart over TIME_WAIT.
  exporter->server_->set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  exporter->server_->set_read_timeout(kIoTimeoutSeconds, 0);
  exporter->server_->set_write_timeout(kIoTimeoutSeconds, 0);
  exporter->server_->set_keep_alive_timeout(kIoTimeoutSeconds);
  exporter->server_->new_task_queue = [] { return new httplib::ThreadPool(kWorkers); };
  exporter->server_->Get("/metrics", [&registry](const httplib::Request&, httplib::Response& res) {
    res.set_content(registry.Serialize(), "text/plain; version=0.0.4; charset=utf-8");
  });
  const int bound = port == 0 ? exporter->server_->bind_to_any_port(host)
                              : (exporter->server_->bind_to_port(host, port) ? port : -1);
  if (bound < 0) {
    return absl::UnavailableError(absl::StrCat("metrics: cannot listen on ", host, ":", port));
  }
  exporter->port_ = bound;
  exporter->thread_ =
      std::thread([server = exporter->server_.get()] { server->listen_after_bind(); });
  return exporter;
}

HttpExporter::~HttpExporter() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace scanprep::metrics
