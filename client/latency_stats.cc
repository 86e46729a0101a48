// SPDX-License-Identifier: Apache-2.0
#include "client/latency_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace scanprep::client {

double NearestRankPercentile(const std::vector<double>& sorted, double q) {
  const double rank = std::ceil(q * static_cast<double>(sorted.size()));
  const size_t index = static_cast<size_t>(std::clamp(rank, 1.0, double(sorted.size()))) - 1;
  return sorted[index];
}

LatencySummary Summarize(std::vector<double> seconds) {
  LatencySummary s;
  s.count = seconds.size();
  if (seconds.empty()) return s;
  std::sort(seconds.begin(), seconds.end());
  s.mean = std::accumulate(seconds.begin(), seconds.end(), 0.0) / double(seconds.size());
  s.p50 = NearestRankPercentile(seconds, 0.50);
  s.p90 = NearestRankPercentile(seconds, 0.90);
  s.p99 = NearestRankPercentile(seconds, 0.99);
  s.max = seconds.back();
  return s;
}

}  // namespace scanprep::client
