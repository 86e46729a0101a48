// SPDX-License-Identifier: Apache-2.0
// `scanprep load`: a bounded load test of a ScanPrep deployment with one replayed job.
#include <cmath>
#include <fstream>
#include <iostream>
#include <optional>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/call_flags.h"
#include "client/commands.h"
#include "client/connection_flags.h"
#include "client/job_builder.h"
#include "client/load_generator.h"
#include "client/load_report.h"
#include "client/scan_generator.h"
#include "client/scanprep_client.h"
#include "core/base/status_macros.h"

namespace scanprep::client {
namespace {

// load's own flags.
constexpr char kConcurrency[] = "concurrency";
constexpr char kDuration[] = "duration";
constexpr char kMaxJobs[] = "max_jobs";
constexpr char kRate[] = "rate";
constexpr char kArrivals[] = "arrivals";
constexpr char kChunkPoints[] = "chunk_points";
constexpr char kAbortUploads[] = "abort_uploads";
constexpr char kJson[] = "json";
constexpr char kRetry[] = "retry";
constexpr char kSimulate[] = "simulate";

absl::StatusOr<LoadOptions> ParseLoadOptions(const ParsedArgs& args) {
  LoadOptions options;
  SCANPREP_ASSIGN_OR_RETURN(auto concurrency, GetNumber(args, kConcurrency, 1, 1));
  if (concurrency > 1024 || concurrency != std::floor(concurrency)) {
    return absl::InvalidArgumentError("--concurrency: a whole number from 1 to 1024");
  }
  options.concurrency = static_cast<int>(concurrency);
  SCANPREP_ASSIGN_OR_RETURN(options.duration, GetDuration(args, kDuration, absl::Seconds(60)));
  if (args.Has(kMaxJobs)) {
    uint64_t max_jobs = 0;
    if (!absl::SimpleAtoi(args.Get(kMaxJobs), &max_jobs) || max_jobs == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("--max_jobs: '", args.Get(kMaxJobs), "' is not a count >= 1"));
    }
    options.max_jobs = max_jobs;
  }
  SCANPREP_ASSIGN_OR_RETURN(options.rate, GetNumber(args, kRate, 0, 0));
  const std::string arrivals = args.Get(kArrivals, "poisson");
  if (arrivals != "poisson" && arrivals != "fixed") {
    return absl::InvalidArgumentError(
        absl::StrCat("--arrivals: '", arrivals, "' is neither poisson nor fixed"));
  }
  options.arrivals = arrivals == "fixed" ? Arrivals::kFixed : Arrivals::kPoisson;
  SCANPREP_ASSIGN_OR_RETURN(auto abort, GetNumber(args, kAbortUploads, 0, 0));
  if (abort >= 1) return absl::InvalidArgumentError("--abort_uploads: a share in [0, 1)");
  options.abort_uploads = abort;
  SCANPREP_ASSIGN_OR_RETURN(auto chunk, GetNumber(args, kChunkPoints, kDefaultChunkPoints, 1));
  if (chunk != std::floor(chunk) || chunk > 1e9) {
    return absl::InvalidArgumentError(
        "--chunk_points: a whole number from 1 (the server's "
        "limit is in `scanprep info`)");
  }
  options.chunk_points = static_cast<size_t>(chunk);
  options.retry = args.Get(kRetry, "true") == "true";
  return options;
}

// --simulate's scan as the flags describe it, nothing for a job of SCAN files. Only the command
// line is checked: INVALID_ARGUMENT is a usage error.
absl::StatusOr<std::optional<GenerateOptions>> Generation(const ParsedArgs& args) {
  if (!args.Has(kSimulate)) return std::nullopt;
  if (!args.positional.empty()) {
    return absl::InvalidArgumentError("give SCAN files or --simulate POINTS, not both");
  }
  size_t points = 0;
  if (!absl::SimpleAtoi(args.Get(kSimulate), &points)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--simulate: '", args.Get(kSimulate), "' is not a point count"));
  }
  SCANPREP_RETURN_IF_ERROR(CheckGeneratedJobFlags(args));
  return ParseGenerateOptions(args, points);
}

absl::StatusOr<Job> LoadJob(const ParsedArgs& args,
                            const std::optional<GenerateOptions>& generation) {
  if (!generation) return BuildJob(args);
  SCANPREP_ASSIGN_OR_RETURN(auto cloud, GenerateScan(*generation));
  return BuildJobFromCloud(args, std::move(cloud));
}

int RunLoadCommand(const ParsedArgs& args) {
  if (!args.Has(kServerFlag)) {
    return FailUsage("load", "--server HOST:PORT is required (no default)");
  }
  auto options = ParseLoadOptions(args);
  if (!options.ok()) return FailUsage("load", std::string(options.status().message()));
  auto flags = CallFlags::Parse(args);
  if (!flags.ok()) return FailUsage("load", std::string(flags.status().message()));
  // The run fails when latency p99 exceeds the budget, which no call meets at 0 s.
  if (flags->budget_seconds && *flags->budget_seconds <= 0) {
    return FailUsage("load", "--budget: seconds > 0");
  }
  options->call_timeout = flags->timeout;
  if (absl::Status s = CheckJobFlags(args); !s.ok()) {
    return FailUsage("load", std::string(s.message()));
  }
  auto generation = Generation(args);
  if (!generation.ok()) return FailUsage("load", std::string(generation.status().message()));
  auto credentials = CredentialsFromArgs(args);
  if (!credentials.ok()) return FailFlagFiles("load", credentials.status());
  // The scans are read (or generated) once; every call replays the same job.
  auto job = LoadJob(args, *generation);
  if (!job.ok()) return Fail("load", std::string(job.status().message()));
  for (const std::string& note : job->notes) std::cerr << "note: " << note << "\n";
  flags->SetBudget(job->header);

  const std::string& target = flags->server;
  std::shared_ptr<grpc::Channel> channel = RoundRobinChannel(target, *credentials);
  // An unreachable or refusing server fails here, once, rather than as a flood of errors.
  if (auto info = ScanPrepClient(channel).GetInfo(absl::Seconds(10)); !info.ok()) {
    return FailCall("load", target, info.status());
  }
  const LoadReport report = MakeLoadReport(
      target, *options, *job, GenerateLoad(channel, *job, *options), flags->budget_seconds);
  PrintLoadReport(std::cout, report);
  if (args.Has(kJson)) {
    std::ofstream out(args.Get(kJson));
    out << LoadReportJson(report);
    if (!out) return Fail("load", absl::StrCat("cannot write ", args.Get(kJson)));
  }
  return report.failures.empty() ? 0 : 1;
}

}  // namespace

Command LoadCommand() {
  std::vector<FlagSpec> flags = {
      {kConcurrency, FlagSpec::kValue, "workers, i.e. calls in flight at most (default 1)"},
      {kDuration, FlagSpec::kValue, "no call starts after this, e.g. 60s (default 60s)"},
      {kMaxJobs, FlagSpec::kValue, "also stop after starting this many calls"},
      {kRate, FlagSpec::kValue,
       "open loop: start this many jobs/s in total (default: closed loop, calls back to back)"},
      {kArrivals, FlagSpec::kValue, "open-loop spacing: poisson (default) or fixed"},
      {kChunkPoints, FlagSpec::kValue, "points per upload message (default 32768)"},
      {kAbortUploads, FlagSpec::kValue,
       "share of calls in [0, 1), spread evenly, cancelled by the client once the server "
       "confirmed their first chunk (default 0); the others must still succeed"},
      {kJson, FlagSpec::kValue, "also write the results as JSON to this file"},
      {kRetry, FlagSpec::kBool,
       "send a call the server refused with RetryInfo (RESOURCE_EXHAUSTED, UNAVAILABLE) again "
       "after its delay (at most 10 s, plus jitter) within the call's --timeout, counted as "
       "retried, not as an error (default true; --retry=false counts every refusal as an "
       "error)"},
  };
  for (FlagSpec& flag : CallFlagSpecs(/*server_required=*/true)) flags.push_back(std::move(flag));
  flags.push_back({kSimulate, FlagSpec::kValue,
                   "replay a generated laser-line scan of about this many points instead of "
                   "SCAN files (millimetres; see `scanprep simulate`)"});
  for (FlagSpec& flag : GenerateFlags()) flags.push_back(std::move(flag));
  return Command{
      .name = "load",
      .synopsis =
          "load --server HOST:PORT (SCAN... | --simulate POINTS) [--concurrency N] "
          "[--duration 60s] [flags]",
      .summary =
          "load-test the service with one job (the scans, read once) replayed by N "
          "workers; prints jobs/s, points/s, latency percentiles and errors by status "
          "code; exits 1 on any failed call or when latency p99 exceeds the budget",
      .flags = std::move(flags),
      .run = RunLoadCommand,
  };
}

}  // namespace scanprep::client
