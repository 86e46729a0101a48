// SPDX-License-Identifier: Apache-2.0
// Reading the server's /metrics endpoint in tests: one scrape as text or as samples keyed by
// "name{labels}" exactly as exposed, and a bounded wait for a sample to reach a value.
#pragma once

#include <chrono>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <httplib.h>
// httplib includes <resolv.h>, whose `_res` macro breaks Eigen headers included after this one.
#undef _res

namespace scanprep::testing {

// The key of a grpc_server_* series of the ScanPrep service: `method` is "Process" or "GetInfo";
// with `code` (the gRPC ecosystem's spelling: "OK", "InvalidArgument", "Canceled", ...) the
// grpc_server_handled_total series, else `metric`'s.
inline std::string GrpcKey(const std::string& metric, const std::string& method,
                           const std::string& code = "") {
  const std::string type = method == "Process" ? "bidi_stream" : "unary";
  return metric + "{grpc_type=\"" + type +
         "\",grpc_service=\"scanprep.v1.ScanPrep\",grpc_method=\"" + method + "\"" +
         (code.empty() ? "" : ",grpc_code=\"" + code + "\"") + "}";
}
inline std::string GrpcHandled(const std::string& method, const std::string& code) {
  return GrpcKey("grpc_server_handled_total", method, code);
}

inline std::string ScrapeText(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(5, 0);
  auto response = client.Get("/metrics");
  if (!response || response->status != 200) {
    ADD_FAILURE() << "GET /metrics on port " << port << " failed";
    return {};
  }
  EXPECT_EQ(response->get_header_value("Content-Type"), "text/plain; version=0.0.4; charset=utf-8");
  return response->body;
}

inline std::map<std::string, double> ParseSamples(const std::string& text) {
  std::map<std::string, double> samples;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.rfind(' ');
    samples[line.substr(0, space)] = std::stod(line.substr(space + 1));
  }
  return samples;
}

inline std::map<std::string, double> Scrape(int port) { return ParseSamples(ScrapeText(port)); }

// The value of `key` in a scrape (-1 when absent).
inline double Sample(int port, const std::string& key) {
  const auto samples = Scrape(port);
  const auto it = samples.find(key);
  return it == samples.end() ? -1 : it->second;
}

// Scrapes until `key` equals `value` or 10 s passed; true when it did.
inline bool WaitForSample(int port, const std::string& key, double value) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (Sample(port, key) != value) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace scanprep::testing
