// SPDX-License-Identifier: Apache-2.0
// The real Prometheus (Debian package `prometheus`) scrapes an in-process server every second;
// after a few jobs its query API must return the stage histogram and RPC counters with the
// server's values. Skipped when prometheus is not installed.
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "tests/server/metrics_scrape.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;

// A loopback port that was free a moment ago (prometheus takes its port from the command line).
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
    port = ntohs(addr.sin_port);
  }
  close(fd);
  return port;
}

// prometheus with a generated config scraping `target` every second, storage in a temp dir;
// killed and cleaned up on destruction.
class PrometheusProcess {
 public:
  explicit PrometheusProcess(int target_port) : port_(FreePort()) {
    char dir_template[] = "/tmp/scanprep_prometheus_XXXXXX";
    dir_ = mkdtemp(dir_template);
    std::ofstream(dir_ / "prometheus.yml")
        << "global:\n  scrape_interval: 1s\n  evaluation_interval: 1s\n"
        << "scrape_configs:\n  - job_name: scanprep\n    static_configs:\n"
        << "      - targets: ['127.0.0.1:" << target_port << "']\n";
    const std::string config = "--config.file=" + (dir_ / "prometheus.yml").string();
    const std::string storage = "--storage.tsdb.path=" + (dir_ / "data").string();
    const std::string listen = "--web.listen-address=127.0.0.1:" + std::to_string(port_);
    const std::string log = (dir_ / "prometheus.log").string();
    pid_ = fork();
    if (pid_ == 0) {
      if (std::freopen(log.c_str(), "w", stdout) == nullptr ||
          std::freopen(log.c_str(), "w", stderr) == nullptr) {
        _exit(127);
      }
      execlp("prometheus", "prometheus", config.c_str(), storage.c_str(), listen.c_str(),
             static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~PrometheusProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  int port() const { return port_; }
  std::string Log() const {
    std::ifstream in(dir_ / "prometheus.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

 private:
  int port_;
  fs::path dir_;
  pid_t pid_ = -1;
};

// The value of the one series of an instant query whose labels end with `last_label`, or -1.
double QueryValue(int port, const std::string& query, const std::string& last_label) {
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(1, 0);
  client.set_read_timeout(2, 0);
  auto response =
      client.Get("/api/v1/query", httplib::Params{{"query", query}}, httplib::Headers{});
  if (!response || response->status != 200) return -1;
  // {"metric":{...,"stage":"outliers"},"value":[1700000000.123,"3"]}; labels come sorted.
  const std::string& body = response->body;
  const size_t series = body.find(last_label + "},\"value\":[");
  if (series == std::string::npos) return -1;
  const size_t open = body.find(",\"", series + last_label.size() + 10);
  const size_t close = body.find('"', open + 2);
  if (open == std::string::npos || close == std::string::npos) return -1;
  return std::stod(body.substr(open + 2, close - open - 2));
}

TEST(Prometheus, ScrapesTheServerAndAnswersQueriesWithItsValues) {
  if (std::system("command -v prometheus >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "prometheus not installed (Debian package 'prometheus')";
  }
  server::ServerOptions options;
  options.metrics_listen = "127.0.0.1:0";
  InProcessServer server(options);
  const int metrics_port = server.server().metrics_port();
  PrometheusProcess prometheus(metrics_port);
  ASSERT_GT(prometheus.port(), 0);

  constexpr int kJobs = 3;
  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("outliers");
  const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);
  for (int i = 0; i < kJobs; ++i) {
    auto result = server.Client().Process(header, scan.cloud);
    ASSERT_TRUE(result.ok()) << result.status();
  }

  // Bounded wait: Prometheus starts, scrapes once a second; the query answers once it has.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  double stage_count = -1;
  while ((stage_count = QueryValue(prometheus.port(), "scanprep_stage_duration_seconds_count",
                                   "\"stage\":\"outliers\"")) != kJobs &&
         std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_EQ(stage_count, kJobs) << "prometheus log:\n" << prometheus.Log();
  EXPECT_EQ(QueryValue(prometheus.port(),
                       "grpc_server_handled_total{grpc_method=\"Process\",grpc_code=\"OK\"}",
                       "\"job\":\"scanprep\""),
            kJobs);
  EXPECT_EQ(QueryValue(prometheus.port(), "scanprep_points_received_total", "\"job\":\"scanprep\""),
            kJobs * static_cast<double>(scan.cloud.size()));
  EXPECT_EQ(QueryValue(prometheus.port(), "up", "\"job\":\"scanprep\""), 1);
  EXPECT_EQ(QueryValue(prometheus.port(), "scanprep_queue_capacity", "\"job\":\"scanprep\""), 8);
}

}  // namespace
}  // namespace scanprep::testing
