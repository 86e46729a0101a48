// SPDX-License-Identifier: Apache-2.0
// /metrics against slow-header clients: sockets that send half a request line and stop must not
// keep a scrape from being answered (with httplib's defaults, eight of them blocked every scrape
// for 5 s).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
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

// A connected socket that has sent a partial request header; closed on destruction.
class PartialHeader {
 public:
  explicit PartialHeader(int port) : fd_(socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = fd_ >= 0 &&
                 connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                 send(fd_, kPartial, sizeof(kPartial) - 1, 0) == sizeof(kPartial) - 1;
  }
  ~PartialHeader() {
    if (fd_ >= 0) close(fd_);
  }
  bool connected() const { return connected_; }

 private:
  static constexpr char kPartial[] = "GET /metrics HTTP/1.1\r\nHost: x";
  int fd_;
  bool connected_ = false;
};

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

}  // namespace
}  // namespace scanprep::testing
