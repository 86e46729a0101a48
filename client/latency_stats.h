// SPDX-License-Identifier: Apache-2.0
// Latency percentiles of a load run. Nearest-rank percentiles (an observed value, never an
// interpolation), so p50 <= p90 <= p99 <= max always holds.
#pragma once

#include <cstddef>
#include <vector>

namespace scanprep::client {

struct LatencySummary {
  size_t count = 0;
  double mean = 0, p50 = 0, p90 = 0, p99 = 0, max = 0;  // seconds; all 0 when count == 0
};

// The smallest sample with at least fraction `q` (in (0, 1]) of the samples at or below it.
// `sorted` is ascending and not empty.
double NearestRankPercentile(const std::vector<double>& sorted, double q);

LatencySummary Summarize(std::vector<double> seconds);

}  // namespace scanprep::client
