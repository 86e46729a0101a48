// `scanprep process SCAN... -o OUT.ply`: one job through the service, result to a PLY file.
#include <fstream>
#include <iostream>

#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "client/commands.h"
#include "client/job_builder.h"
#include "client/progress_view.h"
#include "client/scanprep_client.h"
#include "core/io/ply.h"

namespace scanprep::client {
namespace {

int RunProcess(const ParsedArgs& args) {
  if (!args.Has("out")) return Fail("process", "-o OUT.ply is required");
  auto job = BuildJob(args);
  if (!job.ok()) return Fail("process", std::string(job.status().message()));
  for (const std::string& note : job->notes) std::cerr << "note: " << note << "\n";

  CallOptions call;
  if (args.Has("timeout")) {
    absl::Duration timeout;
    if (!absl::ParseDuration(args.Get("timeout"), &timeout)) {
      return Fail("process", absl::StrCat("--timeout: '", args.Get("timeout"),
                                          "' is not a duration (e.g. 90s, 5m)"));
    }
    call.timeout = timeout;
  }
  ProgressView view(std::cerr, isatty(STDERR_FILENO) != 0);
  call.progress = [&view](const v1::Progress& p) { view.Update(p); };

  const std::string server = args.Get("server", "localhost:50051");
  auto result = ScanPrepClient::Connect(server).Process(job->header, job->points, call);
  view.Done();
  if (!result.ok()) {
    return Fail("process", absl::StrCat(server, ": ", absl::StatusCodeToString(result.status().code()),
                                        ": ", result.status().message()));
  }
  const std::string out = args.Get("out");
  io::PlyWriteOptions ply_options{.include_removed = job->header.options().include_removed()};
  if (absl::Status s = io::WritePly(out, result->cloud, ply_options); !s.ok()) {
    return Fail("process", std::string(s.message()));
  }
  if (args.Has("report_json")) {
    std::string json;
    google::protobuf::util::JsonPrintOptions json_options;
    json_options.add_whitespace = true;
    (void)google::protobuf::util::MessageToJsonString(result->report, &json, json_options);
    std::ofstream(args.Get("report_json")) << json;
  }
  PrintSummary(std::cout, result->report);
  std::cout << "wrote " << result->cloud.size() << " points to " << out << "\n";
  return 0;
}

}  // namespace

Command ProcessCommand() {
  return Command{
      .name = "process",
      .synopsis = "process SCAN... -o OUT.ply [flags]",
      .summary = "send scans (one scan per file, .ply or .xyz) through the service; write the "
                 "result as binary PLY with normals and flags",
      .flags =
          {
              {"out", FlagSpec::kValue, "output PLY file (required)", "o"},
              {"server", FlagSpec::kValue, "HOST:PORT of the service (default localhost:50051)"},
              {"unit", FlagSpec::kValue,
               "length unit of the files: m, mm, um or in (default: the job file's, else mm)"},
              {"job", FlagSpec::kValue, "JobHeader as JSON; the flags below override it"},
              {"conf", FlagSpec::kValue,
               "scanalyze .conf with each file's pose (sent as to_common; the server applies it)"},
              {"stages", FlagSpec::kValue, "comma-separated stage list (see `scanprep info`)"},
              {"param", FlagSpec::kRepeated, "parameter override name=value"},
              {"scanline_spacing", FlagSpec::kValue, "scanline spacing of every scan, job unit"},
              {"uncertainty", FlagSpec::kValue, "measuring uncertainty of every scan, job unit"},
              {"include_removed", FlagSpec::kBool, "also write removed points, flagged"},
              {"timeout", FlagSpec::kValue, "deadline for the whole call, e.g. 120s"},
              {"report_json", FlagSpec::kValue, "also write the full report as JSON"},
          },
      .run = RunProcess,
  };
}

}  // namespace scanprep::client
