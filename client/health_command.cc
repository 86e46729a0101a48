// SPDX-License-Identifier: Apache-2.0
// `scanprep health SCAN... [--conf F | --job F]`: the scans' and overlapping pairs' health (issue
// 32) without cleaning them: the job asks for the "health" stage alone, the service runs only
// what it needs (the plan adds its prerequisites), and no cloud is written.
#include <iostream>
#include <variant>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/call_error.h"
#include "client/call_flags.h"
#include "client/commands.h"
#include "client/health_table.h"
#include "client/job_call.h"
#include "client/progress_view.h"

namespace scanprep::client {
namespace {

int RunHealth(const ParsedArgs& args) {
  auto sent = SendJob("health", args, [](Job& job) {
    v1::PipelineOptions& options = *job.header.mutable_options();
    options.clear_stages();
    options.add_stages("health");
    // The answer is the report: no cloud comes back.
    job.header.set_result_arrays(v1::ARRAY_ENCODING_NONE);
  });
  if (const int* exit = std::get_if<int>(&sent)) return *exit;
  SentJob& job = std::get<SentJob>(sent);
  job.phases.total = absl::ToDoubleSeconds(absl::Now() - job.start);
  const v1::Report& report = job.result.report;
  if (const int exit = WriteReportJson("health", args, report, job.phases, "measured the health");
      exit != kExitOk) {
    return exit;
  }
  PrintHealth(std::cout, report);
  // As in `process`: a unit that looks wrong, say, makes every number above wrong.
  PrintWarnings(std::cout, report);
  PrintPhases(std::cout, job.phases);
  return BudgetExit("health", args, report);
}

}  // namespace

// `process`'s job flags but --stages: the job runs the "health" stage and what it needs.
std::vector<FlagSpec> HealthFlags() {
  std::vector<FlagSpec> flags = JobCallFlags();
  std::erase_if(flags, [](const FlagSpec& f) { return f.name == CallFlags::kStages; });
  return flags;
}

Command HealthCommand() {
  return Command{
      .name = "health",
      .synopsis = "health SCAN... [--conf F | --job F] [flags]  (SCAN '-': standard input)",
      .summary =
          "measure the scans' health without cleaning them: per scan the noise, its ratio "
          "to the stated uncertainty, outlier/merged/invalid shares and viewing angles; per "
          "overlapping pair the point-to-plane residual and the rigid misalignment. Reads "
          "the scans as `process` does; writes no cloud",
      .flags = HealthFlags(),
      .run = RunHealth,
  };
}

}  // namespace scanprep::client
