// SPDX-License-Identifier: Apache-2.0
// /metrics against slow-header clients: sockets that send half a request line and stop, or trickle
// it, or send nothing, must not keep a scrape from being answered (with httplib's defaults, eight
// of them blocked every scrape for 5 s; with its 16-worker pool, 1,000 did for minutes).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "server/metrics/http_exporter.h"
#include "server/metrics/registry.h"
#include "tests/server/metrics_scrape.h"

namespace scanprep::testing {
namespace {

// A connected socket that has sent a partial request header (none with `idle`); closed on
// destruction.
class PartialHeader {
 public:
  explicit PartialHeader(int port, bool idle = false) : fd_(socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = fd_ >= 0 &&
                 connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                 (idle || send(fd_, kPartial, sizeof(kPartial) - 1, 0) == sizeof(kPartial) - 1);
  }
  ~PartialHeader() {
    if (fd_ >= 0) close(fd_);
  }
  bool connected() const { return connected_; }
  // One more byte of a header that never ends (errors ignored: the server may have closed it).
  void Trickle() { send(fd_, "x", 1, MSG_NOSIGNAL | MSG_DONTWAIT); }

 private:
  static constexpr char kPartial[] = "GET /metrics HTTP/1.1\r\nHost: x";
  int fd_;
  bool connected_ = false;
};

// A connected socket that has sent a whole GET /metrics and never reads the answer; closed on
// destruction.
class NeverReads {
 public:
  explicit NeverReads(int port) : fd_(socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    static constexpr char kRequest[] = "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n";
    connected_ = fd_ >= 0 &&
                 connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                 send(fd_, kRequest, sizeof(kRequest) - 1, MSG_NOSIGNAL) == sizeof(kRequest) - 1;
  }
  ~NeverReads() {
    if (fd_ >= 0) close(fd_);
  }
  bool connected() const { return connected_; }

 private:
  int fd_;
  bool connected_ = false;
};

// Both ends of a few thousand sockets live in the test process; false when it may not have them.
bool RaiseFileLimit(rlim_t files_needed) {
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) != 0) return false;
  if (files.rlim_cur < files_needed && files.rlim_max >= files_needed) {
    files.rlim_cur = files_needed;
    if (setrlimit(RLIMIT_NOFILE, &files) != 0) return false;
  }
  return files.rlim_cur >= files_needed;
}

double SecondsToScrape(int port, std::string* text) {
  const auto start = std::chrono::steady_clock::now();
  *text = ScrapeText(port);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TEST(MetricsSlowClients, PartialHeadersDoNotBlockAScrape) {
  metrics::Registry registry;
  registry.AddCounter("slow_test_total", "a sample to scrape").WithLabels({}).Inc();
  auto exporter = metrics::HttpExporter::Start("127.0.0.1", 0, registry);
  ASSERT_TRUE(exporter.ok()) << exporter.status();

  // More than the exporter's workers, so the read timeout (not only the pool size) is exercised.
  constexpr int kSlowClients = 24;
  std::vector<std::unique_ptr<PartialHeader>> slow;
  for (int i = 0; i < kSlowClients; ++i) {
    slow.push_back(std::make_unique<PartialHeader>((*exporter)->port()));
    ASSERT_TRUE(slow.back()->connected()) << "slow client " << i;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // let the server accept them all

  const auto start = std::chrono::steady_clock::now();
  const std::string text = ScrapeText((*exporter)->port());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(text.find("slow_test_total 1"), std::string::npos) << text;
  EXPECT_LT(seconds, 2.5) << "scrape behind " << kSlowClients << " slow-header clients";
}

// 1,000 sockets held open on the metrics port: half connected and silent, half sending a header
// that never ends, one byte every 100 ms. Every scrape meanwhile is answered within a second.
TEST(MetricsSlowClients, AThousandIdleAndTricklingSocketsDoNotDelayAScrape) {
  if (!RaiseFileLimit(4096)) GTEST_SKIP() << "RLIMIT_NOFILE below 4096";

  metrics::Registry registry;
  registry.AddCounter("slow_test_total", "a sample to scrape").WithLabels({}).Inc();
  auto exporter = metrics::HttpExporter::Start("127.0.0.1", 0, registry);
  ASSERT_TRUE(exporter.ok()) << exporter.status();
  const int port = (*exporter)->port();

  constexpr int kSockets = 1'000;
  std::vector<std::unique_ptr<PartialHeader>> held;
  for (int i = 0; i < kSockets; ++i) {
    held.push_back(std::make_unique<PartialHeader>(port, /*idle=*/i % 2 == 0));
    ASSERT_TRUE(held.back()->connected()) << "socket " << i;
  }
  std::atomic<bool> stop{false};
  std::thread trickle([&] {
    while (!stop) {
      for (size_t i = 1; i < held.size(); i += 2) held[i]->Trickle();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });

  // Three scrapes, the last after the first sockets' deadline: as they are dropped and the rest
  // trickle on.
  for (int scrape = 0; scrape < 3; ++scrape) {
    std::string text;
    const double seconds = SecondsToScrape(port, &text);
    EXPECT_NE(text.find("slow_test_total 1"), std::string::npos) << "scrape " << scrape;
    EXPECT_LT(seconds, 1.0) << "scrape " << scrape << " behind " << kSockets << " sockets";
    std::this_thread::sleep_for(std::chrono::milliseconds(800));
  }
  stop = true;
  trickle.join();
}

// Issue 39 finding 6: sockets that send GET /metrics and never read, 250 more before each of 8
// scrapes, against a 1.4 MB body (what unbounded sensor series made). With a body rendered per
// connection and the oldest answers closed for newer arrivals, the scrapes took 2.4-3.0 s and
// half came back cut. One rendering per round shared, at most 64 answers written at once and a
// stalled one giving its place to a waiting request: every scrape whole, in about 0.5 s on two
// cores (the bound leaves room for a loaded machine).
TEST(MetricsSlowClients, TwoThousandScrapersThatNeverReadDelayAndCutNoScrape) {
  if (!RaiseFileLimit(4096)) GTEST_SKIP() << "RLIMIT_NOFILE below 4096";
  metrics::Registry registry;
  auto& big = registry.AddGauge("big_test_series", "a large body", {"sensor"});
  for (int i = 0; i < 10'000; ++i)
    big.WithLabels({std::string(100, 'a' + i % 26) + std::to_string(i)}).Set(i);
  const size_t body_bytes = registry.Serialize().size();
  ASSERT_GT(body_bytes, 1'300'000u);
  auto exporter = metrics::HttpExporter::Start("127.0.0.1", 0, registry);
  ASSERT_TRUE(exporter.ok()) << exporter.status();
  const int port = (*exporter)->port();

  // Before each scrape 250 more, so that every one comes behind requests of its own.
  std::vector<std::unique_ptr<NeverReads>> held;
  for (int scrape = 0; scrape < 8; ++scrape) {
    for (int i = 0; i < 250; ++i) {
      held.push_back(std::make_unique<NeverReads>(port));
      ASSERT_TRUE(held.back()->connected()) << "socket " << held.size();
    }
    std::string text;
    const double seconds = SecondsToScrape(port, &text);
    std::printf("scrape %d behind %zu sockets that never read: %.3f s, %zu bytes\n", scrape,
                held.size(), seconds, text.size());
    EXPECT_EQ(text.size(), body_bytes) << "scrape " << scrape << " cut short";
    EXPECT_LT(seconds, 2.0) << "scrape " << scrape;
  }
}

}  // namespace
}  // namespace scanprep::testing
