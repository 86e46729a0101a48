// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/http_exporter.h"

#include <netdb.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <list>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace scanprep::metrics {
namespace {

using Clock = std::chrono::steady_clock;

// One client connection: reading its request, then writing the answer.
struct Connection {
  int fd;
  Clock::time_point deadline;
  std::string request;
  std::string answer;  // empty while reading
  size_t sent = 0;
};

std::string Answer(absl::string_view status, absl::string_view content_type,
                   absl::string_view body) {
  return absl::StrCat("HTTP/1.1 ", status, "\r\nContent-Type: ", content_type,
                      "\r\nContent-Length: ", body.size(), "\r\nConnection: close\r\n\r\n", body);
}

// The answer to a complete request header: /metrics for GET, else 404 or 405.
std::string Respond(absl::string_view header, const Registry& registry) {
  const absl::string_view line = header.substr(0, header.find("\r\n"));
  const size_t space = line.find(' ');
  const absl::string_view method = line.substr(0, space);
  absl::string_view target =
      space == absl::string_view::npos ? absl::string_view() : line.substr(space + 1);
  target = target.substr(0, target.find(' '));
  const absl::string_view path = target.substr(0, target.find('?'));
  if (path != "/metrics") return Answer("404 Not Found", "text/plain", "not found\n");
  if (method != "GET") return Answer("405 Method Not Allowed", "text/plain", "GET only\n");
  return Answer("200 OK", "text/plain; version=0.0.4; charset=utf-8", registry.Serialize());
}

// Sends what the client takes now; whether the connection stays open (part of the answer left
// and the client's buffer full).
bool SendSome(Connection& c) {
  while (c.sent < c.answer.size()) {
    const ssize_t n = send(c.fd, c.answer.data() + c.sent, c.answer.size() - c.sent, MSG_NOSIGNAL);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK;
    c.sent += n;
  }
  return false;
}

// Reads what arrived and answers once the header is complete. False when the connection is done:
// answered in full, closed by the client, or failed.
bool Progress(Connection& c, const Registry& registry) {
  if (!c.answer.empty()) return SendSome(c);
  char buffer[4096];
  for (;;) {
    const ssize_t n = recv(c.fd, buffer, sizeof(buffer), 0);
    if (n == 0) return false;
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK) return false;
      break;
    }
    c.request.append(buffer, n);
    if (c.request.size() > HttpExporter::kMaxRequestBytes) break;
  }
  const size_t end = c.request.find("\r\n\r\n");
  if (end != std::string::npos) {
    c.answer = Respond(absl::string_view(c.request).substr(0, end), registry);
  } else if (c.request.size() > HttpExporter::kMaxRequestBytes) {
    c.answer = Answer("431 Request Header Fields Too Large", "text/plain", "header too long\n");
  } else {
    return true;
  }
  return SendSome(c);
}

}  // namespace

absl::StatusOr<std::unique_ptr<HttpExporter>> HttpExporter::Start(const std::string& host, int port,
                                                                  const Registry& registry) {
  const absl::Status cannot =
      absl::UnavailableError(absl::StrCat("metrics: cannot listen on ", host, ":", port));
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (getaddrinfo(host.empty() ? nullptr : host.c_str(), service.c_str(), &hints, &found) != 0) {
    return cannot;
  }
  std::unique_ptr<HttpExporter> exporter(new HttpExporter(registry));
  for (addrinfo* a = found; a != nullptr && exporter->listener_ < 0; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) continue;
    // SO_REUSEADDR only allows a restart over TIME_WAIT; no SO_REUSEPORT, with which a second
    // server on the same port would start silently and take half the scrapes.
    const int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    if (bind(fd, a->ai_addr, a->ai_addrlen) == 0 && listen(fd, SOMAXCONN) == 0) {
      exporter->listener_ = fd;
    } else {
      close(fd);
    }
  }
  freeaddrinfo(found);
  if (exporter->listener_ < 0) return cannot;
  sockaddr_storage bound{};
  socklen_t length = sizeof(bound);
  getsockname(exporter->listener_, reinterpret_cast<sockaddr*>(&bound), &length);
  exporter->port_ =
      ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                        : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  exporter->wake_ = eventfd(0, EFD_CLOEXEC);
  if (exporter->wake_ < 0) return cannot;
  exporter->thread_ = std::thread([e = exporter.get()] { e->Serve(); });
  return exporter;
}

HttpExporter::~HttpExporter() {
  if (thread_.joinable()) {
    const uint64_t one = 1;
    (void)!write(wake_, &one, sizeof(one));
    thread_.join();
  }
  if (wake_ >= 0) close(wake_);
  if (listener_ >= 0) close(listener_);
}

void HttpExporter::Serve() {
  std::list<Connection> connections;  // accept order: the oldest first
  std::vector<pollfd> fds;
  for (;;) {
    fds.assign({{wake_, POLLIN, 0}, {listener_, POLLIN, 0}});
    Clock::time_point next = Clock::time_point::max();
    for (const Connection& c : connections) {
      fds.push_back({c.fd, static_cast<short>(c.answer.empty() ? POLLIN : POLLOUT), 0});
      next = std::min(next, c.deadline);
    }
    int timeout_ms = -1;
    if (next != Clock::time_point::max()) {
      timeout_ms = static_cast<int>(std::max<int64_t>(
          0, std::chrono::ceil<std::chrono::milliseconds>(next - Clock::now()).count()));
    }
    if (poll(fds.data(), fds.size(), timeout_ms) < 0 && errno != EINTR) return;
    if (fds[0].revents != 0) break;
    // The connections first, so a scrape accepted in an earlier round is answered before new
    // arrivals can push it out.
    const Clock::time_point now = Clock::now();
    size_t i = 2;
    for (auto it = connections.begin(); it != connections.end(); ++i) {
      const bool open = fds[i].revents == 0 || Progress(*it, registry_);
      if (open && now < it->deadline) {
        ++it;
        continue;
      }
      close(it->fd);
      it = connections.erase(it);
    }
    if (fds[1].revents == 0) continue;
    for (int fd; (fd = accept4(listener_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC)) >= 0;) {
      connections.push_back(
          {.fd = fd, .deadline = Clock::now() + std::chrono::milliseconds(kExchangeDeadlineMs)});
      if (connections.size() > kMaxConnections) {
        close(connections.front().fd);
        connections.pop_front();
      }
    }
  }
  for (const Connection& c : connections) close(c.fd);
}

}  // namespace scanprep::metrics
