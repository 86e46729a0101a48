// SPDX-License-Identifier: Apache-2.0
// What `scanprep load` prints and writes: throughput, latency percentiles, errors by status
// code, budget misses, and the pass/fail verdict, as text and as JSON.
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "client/latency_stats.h"
#include "client/load_generator.h"

namespace scanprep::client {

struct LoadReport {
  std::string target;
  LoadOptions options;
  size_t points_per_job = 0;
  size_t scans_per_job = 0;
  LoadResult result;
  LatencySummary latency;
  double jobs_per_second = 0;
  double points_per_second = 0;  // input points of the successful jobs
  // --budget, else the budget the server reported for the job; none = no latency limit.
  std::optional<double> budget_seconds;
  std::vector<std::string> failures;  // why the run fails; empty = passed
};

LoadReport MakeLoadReport(std::string target, const LoadOptions& options, const Job& job,
                          LoadResult result, std::optional<double> budget_flag);

void PrintLoadReport(std::ostream& out, const LoadReport& report);
std::string LoadReportJson(const LoadReport& report);

}  // namespace scanprep::client
