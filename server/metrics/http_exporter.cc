// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/http_exporter.h"

#include <netdb.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <list>
#include <memory>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace scanprep::metrics {
namespace {

using Clock = std::chrono::steady_clock;
using Body = std::shared_ptr<const std::string>;

// One client connection: reading its request, waiting for a place to be answered, then taking
// the answer.
struct Connection {
  int fd;
  Clock::time_point deadline;  // the request's, from the accept; then the answer's
  std::string request;
  bool waiting = false;        // the request is complete, no place to answer it yet
  std::string head;            // the answer before the body; all of it for an error
  Body body;                   // the round's rendering, shared by the answers started in it
  size_t sent = 0;             // bytes of head, then body
  Clock::time_point progress;  // when the client last took part of the answer
  bool answering() const { return !head.empty(); }
};

std::string Head(absl::string_view status, absl::string_view content_type, size_t length) {
  return absl::StrCat("HTTP/1.1 ", status, "\r\nContent-Type: ", content_type,
                      "\r\nContent-Length: ", length, "\r\nConnection: close\r\n\r\n");
}

std::string Refusal(absl::string_view status, absl::string_view body) {
  return absl::StrCat(Head(status, "text/plain", body.size()), body);
}

// The refusal of a request header (404, 405, 431), empty for GET /metrics.
std::string RefusalOf(absl::string_view request) {
  const size_t end = request.find("\r\n\r\n");
  if (end == absl::string_view::npos) {
    return Refusal("431 Request Header Fields Too Large", "header too long\n");
  }
  const absl::string_view line = request.substr(0, std::min(end, request.find("\r\n")));
  const size_t space = line.find(' ');
  const absl::string_view method = line.substr(0, space);
  absl::string_view target =
      space == absl::string_view::npos ? absl::string_view() : line.substr(space + 1);
  target = target.substr(0, target.find(' '));
  const absl::string_view path = target.substr(0, target.find('?'));
  if (path != "/metrics") return Refusal("404 Not Found", "not found\n");
  if (method != "GET") return Refusal("405 Method Not Allowed", "GET only\n");
  return {};
}

// The registry rendered at most once per poll round, shared by every answer started in it: a
// body per connection made each of 2,000 requests render 1.3 MB (issue 39 finding 6).
class RoundBody {
 public:
  explicit RoundBody(const Registry& registry) : registry_(registry) {}
  const Body& Get() {
    if (!body_) body_ = std::make_shared<const std::string>(registry_.Serialize());
    return body_;
  }

 private:
  const Registry& registry_;
  Body body_;
};

void StartAnswer(Connection& c, RoundBody& round, Clock::time_point now) {
  c.waiting = false;
  c.head = RefusalOf(c.request);
  if (c.head.empty()) {
    c.body = round.Get();
    c.head = Head("200 OK", "text/plain; version=0.0.4; charset=utf-8", c.body->size());
  }
  c.deadline = now + std::chrono::milliseconds(HttpExporter::kWriteDeadlineMs);
  c.progress = now;
}

// Sends what the client takes now; whether the connection stays open (part of the answer left
// and the client's buffer full).
bool SendSome(Connection& c, Clock::time_point now) {
  const size_t body_size = c.body ? c.body->size() : 0;
  while (c.sent < c.head.size() + body_size) {
    iovec parts[2];
    size_t count = 0;
    if (c.sent < c.head.size()) parts[count++] = {c.head.data() + c.sent, c.head.size() - c.sent};
    const size_t from = c.sent > c.head.size() ? c.sent - c.head.size() : 0;
    if (from < body_size) {
      parts[count++] = {const_cast<char*>(c.body->data()) + from, body_size - from};
    }
    msghdr message{};
    message.msg_iov = parts;
    message.msg_iovlen = count;
    const ssize_t n = sendmsg(c.fd, &message, MSG_NOSIGNAL);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK;
    c.sent += n;
    c.progress = now;
  }
  return false;
}

// Reads what arrived; the request waits for its answer once its header is complete (or too
// long). False when the client closed the connection or it failed.
bool ReadSome(Connection& c) {
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
  c.waiting = c.request.find("\r\n\r\n") != std::string::npos ||
              c.request.size() > HttpExporter::kMaxRequestBytes;
  return true;
}

short Events(const Connection& c) {
  if (c.answering()) return POLLOUT;
  return c.waiting ? 0 : POLLIN;  // a waiting one is polled for a hang-up only
}

// The answer whose client has taken nothing for the longest, kStalledMs at least; end() if none.
std::list<Connection>::iterator MostStalled(std::list<Connection>& connections,
                                            Clock::time_point now) {
  auto most = connections.end();
  for (auto it = connections.begin(); it != connections.end(); ++it) {
    if (it->answering() && (most == connections.end() || it->progress < most->progress)) most = it;
  }
  const auto stall = std::chrono::milliseconds(HttpExporter::kStalledMs);
  return most != connections.end() && now - most->progress >= stall ? most : connections.end();
}

// When poll must return: the nearest deadline, or the moment the most stalled answer may be
// closed for a request that waits while every place is taken.
int TimeoutMs(const std::list<Connection>& connections, Clock::time_point now) {
  Clock::time_point next = Clock::time_point::max();
  int answering = 0;
  bool waiting = false;
  for (const Connection& c : connections) {
    next = std::min(next, c.deadline);
    answering += c.answering();
    waiting |= c.waiting;
  }
  if (waiting && answering >= HttpExporter::kMaxAnswering) {
    Clock::time_point oldest = now;
    for (const Connection& c : connections) {
      if (c.answering()) oldest = std::min(oldest, c.progress);
    }
    next = std::min(next, oldest + std::chrono::milliseconds(HttpExporter::kStalledMs));
  }
  if (next == Clock::time_point::max()) return -1;
  return static_cast<int>(
      std::max<int64_t>(0, std::chrono::ceil<std::chrono::milliseconds>(next - now).count()));
}

// Reads requests and sends answers where poll said so; closes what is done or past its deadline.
void Exchange(std::list<Connection>& connections, const std::vector<pollfd>& fds,
              Clock::time_point now) {
  size_t i = 2;
  for (auto it = connections.begin(); it != connections.end(); ++i) {
    const bool open = fds[i].revents == 0 || (it->answering() ? SendSome(*it, now) : ReadSome(*it));
    if (open && now < it->deadline) {
      ++it;
      continue;
    }
    close(it->fd);
    it = connections.erase(it);
  }
}

// Answers the waiting requests, oldest first, while there is a place: a free one, or that of an
// answer stalled for kStalledMs (a client that does not read gives up its place to one that
// asks; one that reads is never stalled that long).
void StartAnswers(std::list<Connection>& connections, const Registry& registry,
                  Clock::time_point now) {
  int answering = 0;
  for (const Connection& c : connections) answering += c.answering();
  RoundBody round(registry);
  for (auto it = connections.begin(); it != connections.end();) {
    if (!it->waiting) {
      ++it;
      continue;
    }
    if (answering >= HttpExporter::kMaxAnswering) {
      const auto stalled = MostStalled(connections, now);
      if (stalled == connections.end()) return;
      close(stalled->fd);
      connections.erase(stalled);
      --answering;
    }
    StartAnswer(*it, round, now);
    if (SendSome(*it, now)) {
      ++answering;
      ++it;
    } else {
      close(it->fd);
      it = connections.erase(it);
    }
  }
}

// Accepts what is pending; past kMaxConnections the oldest connection not being answered is
// closed (answers are bounded by kMaxAnswering and their deadline, and a scrape being answered
// must not be cut short by new arrivals).
void Accept(int listener, std::list<Connection>& connections, Clock::time_point now) {
  for (int fd; (fd = accept4(listener, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC)) >= 0;) {
    setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &HttpExporter::kSendBufferBytes,
               sizeof(HttpExporter::kSendBufferBytes));
    connections.push_back(
        {.fd = fd, .deadline = now + std::chrono::milliseconds(HttpExporter::kRequestDeadlineMs)});
    if (connections.size() <= HttpExporter::kMaxConnections) continue;
    const auto oldest = std::find_if(connections.begin(), connections.end(),
                                     [](const Connection& c) { return !c.answering(); });
    close(oldest->fd);
    connections.erase(oldest);
  }
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
    for (const Connection& c : connections) fds.push_back({c.fd, Events(c), 0});
    if (poll(fds.data(), fds.size(), TimeoutMs(connections, Clock::now())) < 0 && errno != EINTR) {
      return;
    }
    if (fds[0].revents != 0) break;
    // The connections first, so a scrape accepted in an earlier round is answered before new
    // arrivals can push it out.
    const Clock::time_point now = Clock::now();
    Exchange(connections, fds, now);
    StartAnswers(connections, registry_, now);
    if (fds[1].revents != 0) Accept(listener_, connections, now);
  }
  for (const Connection& c : connections) close(c.fd);
}

}  // namespace scanprep::metrics
