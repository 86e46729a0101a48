// SPDX-License-Identifier: Apache-2.0
// `scanprep process SCAN... -o OUT`: one job through the service, the result to a PLY, PCD, LAS or
// XYZ file chosen by the extension.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "client/call_error.h"
#include "client/commands.h"
#include "client/connection_flags.h"
#include "client/job_builder.h"
#include "client/preview.h"
#include "client/progress_view.h"
#include "client/scanprep_client.h"
#include "core/base/status_macros.h"
#include "core/io/scan_file.h"
#include "proto/convert/convert.h"

namespace scanprep::client {
namespace {

namespace fs = std::filesystem;

double SecondsSince(absl::Time start) { return absl::ToDoubleSeconds(absl::Now() - start); }

// The report's JSON with the client's phase timings added as "phases" (the report message
// itself carries only the server's side). Keys are the proto's field names (snake_case), as in
// every JSON the CLI writes (`info --json`, `load --json`, the job file of `simulate`).
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

// Where the result goes: a file, its format by its extension, or standard output ("-") in
// --output_format. Checked before the scans are read or sent.
absl::StatusOr<io::ScanFormat> OutputFormat(const ParsedArgs& args) {
  const std::string out = args.Get("out");
  if (out != "-") {
    if (args.Has("output_format")) {
      return absl::InvalidArgumentError(
          absl::StrCat("--output_format applies to -o - only; ", out, " has its extension"));
    }
    auto format = io::WritableFormatOf(out);
    if (format.ok()) return format;
    return absl::InvalidArgumentError(
        absl::StrCat("-o ", out,
                     ": the result is written as PLY, PCD, LAS or XYZ, chosen by the extension; "
                     "give a file name ending in .ply, .pcd, .las, .xyz, .asc or .txt (or -o - "
                     "with --output_format)"));
  }
  if (!args.Has("output_format")) {
    return absl::InvalidArgumentError(
        "-o - writes the result to standard output: say its format with --output_format (ply, "
        "pcd, las, xyz)");
  }
  auto format = io::ParseScanFormat(args.Get("output_format"));
  if (format.ok() &&
      (!io::Writable(*format) || absl::EqualsIgnoreCase(args.Get("output_format"), "laz"))) {
    return absl::InvalidArgumentError(
        "--output_format: the result is written as ply, pcd, las (uncompressed) or xyz");
  }
  return format;
}

std::string UnitName(v1::LengthUnit unit) {
  switch (unit) {
    case v1::LENGTH_UNIT_METRE:
      return "m";
    case v1::LENGTH_UNIT_MICROMETRE:
      return "um";
    case v1::LENGTH_UNIT_INCH:
      return "in";
    default:
      return "mm";
  }
}

// The input and the result side by side, with how far smoothing moved each kept point. What was
// sent is moved into the result's frame (local: relative to the job's origin) by each scan's
// to_common exactly as the server moves it (server/convert.h, which works in millimetres; the
// result is in job units), and so is the first scan's sensor, which sets the view.
absl::Status WritePreview(const std::string& path, const PointCloud& sent,
                          const v1::JobHeader& header, const PointCloud& result) {
  SCANPREP_ASSIGN_OR_RETURN(const double mm_per_unit, MillimetresPerUnit(header.unit()));
  SCANPREP_ASSIGN_OR_RETURN(const Eigen::Vector3d origin_mm, OriginFromProto(header, mm_per_unit));
  PointCloud input = sent;
  std::vector<ScanFrame> frames;
  ScanMeta scanner;
  for (int s = 0; s < header.scans_size(); ++s) {
    const std::string field = absl::StrCat("header.scans[", s, "]");
    SCANPREP_ASSIGN_OR_RETURN(ScanFrame frame,
                              FrameFromProto(header.scans(s), mm_per_unit, origin_mm, field));
    if (s == 0) {
      SCANPREP_ASSIGN_OR_RETURN(scanner, ScanMetaFromProto(header.scans(0), frame, field));
      if (scanner.camera_position) *scanner.camera_position /= mm_per_unit;
    }
    frames.push_back(frame);
  }
  for (size_t i = 0; i < input.size(); ++i) {
    const size_t s = input.scan.empty() ? 0 : input.scan[i];
    if (s >= frames.size()) continue;
    const Eigen::Vector3d p = frames[s].ChunkPoint(input.point(i).cast<double>()) / mm_per_unit;
    input.x[i] = static_cast<float>(p.x());
    input.y[i] = static_cast<float>(p.y());
    input.z[i] = static_cast<float>(p.z());
  }
  PreviewPanels panels{.input = &input, .result = &result, .unit = UnitName(header.unit())};
  if (input.size() == result.size()) {
    panels.displacement.resize(result.size());
    for (size_t i = 0; i < result.size(); ++i) {
      panels.displacement[i] = result.removed(i) ? 0 : (result.point(i) - input.point(i)).norm();
    }
  }
  return WritePng(path, RenderPreview(panels, ChooseView(result, scanner)));
}

int RunProcess(const ParsedArgs& args) {
  if (!args.Has("out")) return FailUsage("process", "-o OUT.ply is required");
  auto out_format = OutputFormat(args);
  if (!out_format.ok()) return FailUsage("process", std::string(out_format.status().message()));
  if (auto in = ScanArgumentFormats(args); !in.ok()) {
    return FailUsage("process", std::string(in.status().message()));
  }
  if (absl::Status s = CheckJobFlags(args); !s.ok()) {
    return FailUsage("process", std::string(s.message()));
  }
  if (args.Has("preview")) {
    if (absl::Status s = CheckPreviewPath(args.Get("preview")); !s.ok()) {
      return FailUsage("process", std::string(s.message()));
    }
  }
  std::optional<double> budget;
  if (args.Has("budget")) {
    auto seconds = GetNumber(args, "budget", 0, 0);
    if (!seconds.ok()) return FailUsage("process", std::string(seconds.status().message()));
    budget = *seconds;
  }
  CallOptions call;
  if (args.Has("timeout")) {
    auto timeout = GetDuration(args, "timeout", absl::ZeroDuration());
    if (!timeout.ok()) return FailUsage("process", std::string(timeout.status().message()));
    call.timeout = *timeout;
  }
  auto target = ChannelTarget(args.Get("server", "localhost:50051"));
  if (!target.ok()) return FailUsage("process", std::string(target.status().message()));
  auto credentials = CredentialsFromArgs(args);
  if (!credentials.ok()) return FailFlagFiles("process", credentials.status());
  auto mode = ParseProgressMode(args.Get("progress", "auto"), isatty(STDERR_FILENO) != 0);
  if (!mode.ok()) return FailUsage("process", std::string(mode.status().message()));
  const absl::Time start = absl::Now();
  PhaseSeconds phases;
  auto job = BuildJob(args);
  if (!job.ok()) return Fail("process", std::string(job.status().message()));
  if (budget) job->header.mutable_budget()->set_total_seconds(*budget);
  phases.read = SecondsSince(start);
  // The preview shows the removed points, so they come back; the output has them only if asked.
  const bool write_removed = job->header.options().include_removed();
  if (args.Has("preview")) job->header.mutable_options()->set_include_removed(true);
  for (const std::string& note : job->notes) std::cerr << "note: " << note << "\n";

  ProgressView view(std::cerr, *mode);
  call.progress = [&view](const v1::Progress& p) { view.Update(p); };

  const std::string& server = *target;
  auto result =
      ScanPrepClient::Connect(server, *credentials).Process(job->header, job->points, call);
  view.Done();
  if (!result.ok()) {
    return FailCall("process", server, result.status());
  }
  const std::string out = args.Get("out");
  // The result is in the job's unit, the scan files' own, so a LAS input's grid fits it.
  result->cloud.grid = job->points.grid;
  const io::WriteOptions write_options{.include_removed = write_removed};
  const absl::Time write_start = absl::Now();
  // With the result on standard output, what is said about it goes to standard error.
  std::ostream& text = out == "-" ? std::cerr : std::cout;
  if (absl::Status s =
          out == "-" ? io::WriteScanStream(std::cout, *out_format, result->cloud, write_options)
                     : io::WriteScanFile(out, result->cloud, write_options);
      !s.ok()) {
    return Fail("process", std::string(s.message()));
  }
  if (out == "-" && !std::cout.flush()) return Fail("process", "cannot write to standard output");
  phases.write = SecondsSince(write_start);
  phases.total = SecondsSince(start);
  phases.upload = result->transfer.upload;
  phases.processing = result->report.processing_seconds();
  phases.download = result->transfer.download;
  if (args.Has("report_json")) {
    auto json = ReportJson(result->report, phases);
    if (!json.ok()) return Fail("process", std::string(json.status().message()));
    std::ofstream file(args.Get("report_json"));
    file << *json;
    file.close();
    if (!file) {
      return Fail("process", absl::StrCat("wrote ", out, " but cannot write the report to ",
                                          args.Get("report_json")));
    }
  }
  PrintSummary(text, result->report);
  PrintPhases(text, phases);
  if (args.Has("preview")) {
    if (absl::Status s = WritePreview(args.Get("preview"), job->points, job->header, result->cloud);
        !s.ok()) {
      return Fail("process", std::string(s.message()));
    }
    text << "wrote the preview to " << args.Get("preview") << "\n";
  }
  text << "wrote " << (write_removed ? result->cloud.size() : result->cloud.CountKept())
       << " points to " << (out == "-" ? std::string("standard output") : out) << "\n";
  if (args.Bool("fail_on_budget_miss") &&
      result->report.budget_outcome() == v1::BUDGET_OUTCOME_MISSED) {
    std::cerr << "scanprep process: the job missed its budget of "
              << result->report.budget_seconds() << " s (--fail_on_budget_miss)\n";
    return kExitBudgetMissed;
  }
  return kExitOk;
}

}  // namespace

Command ProcessCommand() {
  std::vector<FlagSpec> flags = {
      {"out", FlagSpec::kValue,
       "output file (required): .ply, .pcd, .las or .xyz/.asc/.txt; - for standard output", "o"},
      {"output_format", FlagSpec::kValue, "format of -o -: ply, pcd, las or xyz"},
      {"server", FlagSpec::kValue, absl::StrCat(kServerFlagHelp, " (default localhost:50051)")},
  };
  AddTlsFlags(flags);
  for (FlagSpec& flag : JobFlags()) flags.push_back(std::move(flag));
  flags.push_back({"timeout", FlagSpec::kValue, "deadline for the whole call, e.g. 120s"});
  flags.push_back({"budget", FlagSpec::kValue,
                   "time budget of the job in seconds (over the job file's and the server's "
                   "default); the report says whether it was met"});
  flags.push_back({"fail_on_budget_miss", FlagSpec::kBool,
                   "exit 5 when the job ran over its time budget (--budget or the server's "
                   "default); the output is written all the same"});
  flags.push_back({"progress", FlagSpec::kValue,
                   "progress on stderr: auto (default: live on a terminal, else plain), live (one "
                   "line redrawn), plain (a line when a phase or stage starts, at each quarter "
                   "of it and at least every 10 s) or off"});
  flags.push_back({"preview", FlagSpec::kValue,
                   "also draw the input and the result side by side as PNG: removed points by "
                   "reason, edges, smoothing displacement"});
  flags.push_back({"report_json", FlagSpec::kValue,
                   "also write the full report as JSON, with the phase timings under \"phases\""});
  return Command{
      .name = "process",
      .synopsis = "process SCAN... -o OUT.ply [flags]  (SCAN or OUT '-': standard input/output)",
      .summary =
          "send scans (.ply, .pcd, .e57, .las, .xyz/.asc/.txt/.pts; an E57 file holds several) "
          "through "
          "the service; write the result with normals and flags as PLY, PCD, LAS or XYZ (by -o's "
          "extension)",
      .flags = std::move(flags),
      .run = RunProcess,
  };
}

}  // namespace scanprep::client
