// SPDX-License-Identifier: Apache-2.0
#include "client/job_call.h"

#include <fstream>
#include <iostream>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"
#include "client/call_error.h"
#include "client/call_flags.h"
#include "client/commands.h"
#include "client/connection_flags.h"
#include "client/output_check.h"

namespace scanprep::client {
namespace {

// The flags that process and health add to the shared ones (CallFlagSpecs).
constexpr char kFailOnBudgetMiss[] = "fail_on_budget_miss";
constexpr char kProgress[] = "progress";
constexpr char kReportJson[] = "report_json";

double SecondsSince(absl::Time start) { return absl::ToDoubleSeconds(absl::Now() - start); }

}  // namespace

std::vector<FlagSpec> JobCallFlags() {
  std::vector<FlagSpec> flags = CallFlagSpecs(/*server_required=*/false);
  flags.push_back({kFailOnBudgetMiss, FlagSpec::kBool,
                   "exit 5 when the job ran over its time budget (--budget or the server's "
                   "default); the output is written all the same"});
  flags.push_back({kProgress, FlagSpec::kValue,
                   "progress on stderr: auto (default: live on a terminal, else plain), live (one "
                   "line redrawn), plain (a line when a phase or stage starts, at each quarter "
                   "of it and at least every 10 s) or off"});
  flags.push_back({kReportJson, FlagSpec::kValue,
                   "also write the full report as JSON, with the phase timings under \"phases\""});
  return flags;
}

std::variant<int, SentJob> SendJob(const std::string& command, const ParsedArgs& args,
                                   const std::function<void(Job&)>& adjust) {
  if (auto in = ScanArgumentFormats(args); !in.ok()) {
    return FailUsage(command, std::string(in.status().message()));
  }
  if (absl::Status s = CheckJobFlags(args); !s.ok()) {
    return FailUsage(command, std::string(s.message()));
  }
  auto flags = CallFlags::Parse(args);
  if (!flags.ok()) return FailUsage(command, std::string(flags.status().message()));
  auto credentials = CredentialsFromArgs(args);
  if (!credentials.ok()) return FailFlagFiles(command, credentials.status());
  auto mode = ParseProgressMode(args.Get(kProgress, "auto"), isatty(STDERR_FILENO) != 0);
  if (!mode.ok()) return FailUsage(command, std::string(mode.status().message()));
  if (args.Has(kReportJson)) {
    if (absl::Status s = CheckWritable("--report_json", args.Get(kReportJson)); !s.ok()) {
      return Fail(command, std::string(s.message()));
    }
  }
  SentJob sent{.start = absl::Now(), .server = flags->server};
  auto job = BuildJob(args);
  if (!job.ok()) return Fail(command, std::string(job.status().message()));
  sent.job = std::move(*job);
  flags->SetBudget(sent.job.header);
  adjust(sent.job);
  sent.phases.read = SecondsSince(sent.start);
  for (const std::string& note : sent.job.notes) std::cerr << "note: " << note << "\n";

  ProgressView view(std::cerr, *mode);
  CallOptions call{.timeout = flags->timeout};
  call.progress = [&view](const v1::Progress& p) { view.Update(p); };
  auto result = ScanPrepClient::Connect(sent.server, *credentials)
                    .Process(sent.job.header, sent.job.points, call);
  view.Done();
  if (!result.ok()) return FailCall(command, sent.server, result.status());
  sent.result = std::move(*result);
  sent.phases.upload = sent.result.transfer.upload;
  sent.phases.processing = sent.result.report.processing_seconds();
  sent.phases.download = sent.result.transfer.download;
  return sent;
}

absl::StatusOr<std::string> ReportJson(const v1::Report& report, const PhaseSeconds& phases) {
  namespace pb = google::protobuf;
  std::string json;
  pb::Struct root;
  pb::util::JsonPrintOptions names;
  names.preserve_proto_field_names = true;
  if (auto s = pb::util::MessageToJsonString(report, &json, names); !s.ok()) {
    return absl::InternalError(
        absl::StrCat("the report cannot be written as JSON: ", s.ToString()));
  }
  if (auto s = pb::util::JsonStringToMessage(json, &root); !s.ok()) {
    return absl::InternalError(
        absl::StrCat("the report's JSON cannot be read back: ", s.ToString()));
  }
  pb::Struct& out = *(*root.mutable_fields())["phases"].mutable_struct_value();
  const std::pair<const char*, double> values[] = {
      {"read_seconds", phases.read},
      {"upload_seconds", phases.upload},
      {"processing_seconds", phases.processing},
      {"download_seconds", phases.download},
      {"write_seconds", phases.write},
      {"total_seconds", phases.total},
  };
  for (const auto& [name, seconds] : values)
    (*out.mutable_fields())[name].set_number_value(seconds);
  pb::util::JsonPrintOptions options = names;
  options.add_whitespace = true;
  json.clear();
  if (auto s = pb::util::MessageToJsonString(root, &json, options); !s.ok()) {
    return absl::InternalError(
        absl::StrCat("the report cannot be written as JSON: ", s.ToString()));
  }
  return json;
}

int WriteReportJson(const std::string& command, const ParsedArgs& args, const v1::Report& report,
                    const PhaseSeconds& phases, const std::string& done) {
  if (!args.Has(kReportJson)) return kExitOk;
  auto json = ReportJson(report, phases);
  if (!json.ok()) return Fail(command, std::string(json.status().message()));
  std::ofstream file(args.Get(kReportJson));
  file << *json;
  file.close();
  if (!file) {
    return Fail(command,
                absl::StrCat(done, " but cannot write the report to ", args.Get(kReportJson)));
  }
  return kExitOk;
}

int BudgetExit(const std::string& command, const ParsedArgs& args, const v1::Report& report) {
  if (args.Bool(kFailOnBudgetMiss) && report.budget_outcome() == v1::BUDGET_OUTCOME_MISSED) {
    std::cerr << "scanprep " << command << ": the job missed its budget of "
              << report.budget_seconds() << " s (--fail_on_budget_miss)\n";
    return kExitBudgetMissed;
  }
  return kExitOk;
}

}  // namespace scanprep::client
