// SPDX-License-Identifier: Apache-2.0
// What the commands that send scan files as one job share (`process`, `health`): their flags, the
// checks before anything is read, reading the job, the call with progress on standard error, and
// the report as JSON.
#pragma once

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/cli_args.h"
#include "client/job_builder.h"
#include "client/progress_view.h"
#include "client/scanprep_client.h"

namespace scanprep::client {

// --server, TLS, the job flags (JobFlags), --timeout, --budget, --fail_on_budget_miss,
// --progress and --report_json.
std::vector<FlagSpec> JobCallFlags();

struct SentJob {
  Job job;  // as sent
  ProcessResult result;
  absl::Time start;     // before the scans were read
  PhaseSeconds phases;  // read, upload, processing, download; the caller adds write and total
  std::string server;
};

// Checks the flags (a mistake is a usage error, exit 2), reads the scans into a job, lets
// `adjust` change it, prints the job's notes and sends it. On failure prints why, as
// "scanprep <command>: ...", and returns the exit code.
std::variant<int, SentJob> SendJob(const std::string& command, const ParsedArgs& args,
                                   const std::function<void(Job&)>& adjust);

// The report's JSON with the client's phase timings added as "phases" (the report message
// itself carries only the server's side). Keys are the proto's field names (snake_case), as in
// every JSON the CLI writes (`info --json`, `load --json`, the job file of `simulate`).
absl::StatusOr<std::string> ReportJson(const v1::Report& report, const PhaseSeconds& phases);

// --report_json, when given: exit 0, or 1 when it cannot be written (the message says what
// `done` already did, e.g. "wrote out.ply").
int WriteReportJson(const std::string& command, const ParsedArgs& args, const v1::Report& report,
                    const PhaseSeconds& phases, const std::string& done);

// --fail_on_budget_miss: exit 5 (saying so) when the job ran over its budget, else 0.
int BudgetExit(const std::string& command, const ParsedArgs& args, const v1::Report& report);

}  // namespace scanprep::client
